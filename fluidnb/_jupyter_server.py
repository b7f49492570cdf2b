"""A Jupyter server extension: Voila's pages inside a Jupyter server typeset math offline.

Standalone ``voila notebook.ipynb`` typesets the lessons' equations with the MathJax
bundled in its page, with no network. The same notebook opened at
``/voila/render/...`` of a running JupyterLab (and so on Binder) is rendered by
Voila's server extension, which takes MathJax's source from the server's tornado
settings: with no ``mathjax_url`` there, it falls back to a CDN, and offline the page
shows raw LaTeX (133 snippets on the frost lesson). Voila's page uses its bundled
MathJax exactly when both ``mathjax_url`` and ``mathjax_config`` are null (voila
0.5: ``get_page_config`` in voila/utils.py, and the page's check of
``fullMathjaxUrl`` and ``mathjaxConfig``), as the standalone app sets them.

This extension sets both to None in the server's settings, unless someone set either
already. Nothing else reads them in a JupyterLab 4 server (JupyterLab's own math uses
its bundled MathJax 3 whatever they say). It is enabled by the file
``etc/jupyter/jupyter_server_config.d/fluidnb.json`` that installing fluidnb puts in the
environment (pyproject.toml's data-files), so ``python3 dev.py lab``, ``jupyter lab``
and Binder all load it. It imports nothing: the library never imports Jupyter.
"""

__all__ = []


def _jupyter_server_extension_points():
    return [{"module": "fluidnb._jupyter_server"}]


def _load_jupyter_server_extension(serverapp):
    settings = serverapp.web_app.settings
    if "mathjax_url" in settings or "mathjax_config" in settings:
        return  # configured by someone: theirs
    settings["mathjax_url"] = None
    settings["mathjax_config"] = None
    serverapp.log.info("fluidnb: Voila pages use their bundled MathJax (works offline)")
