"""``python -m fluidnb.videodb``: build the starter databases missing from the cache.

What ``python3 dev.py lab`` starts in a background process while JupyterLab opens
(:func:`fluidnb.videodb.prebuild_starters`): water, smoke, then fire, each under the
cache's lock, so that a notebook asking for one waits for it and then opens it. Quick
databases when ``FLUIDNB_QUICK`` is set, as everywhere. Progress goes to stdout, one
line every few seconds (dev.py sends it to a log file in the cache).
"""

if __name__ == "__main__":  # pragma: no cover - run as a process (tests/test_lab_command.py)
    import time

    from .starter import prebuild_starters

    started = time.perf_counter()
    last = [-10.0]

    def log(fraction, message=""):
        """One line every 5 s (a log file), and one when each database is ready."""
        now = time.perf_counter()
        if now - last[0] >= 5.0 or fraction >= 1.0 or message.endswith("database ready"):
            last[0] = now
            print(f"{now - started:6.1f} s {fraction:5.0%} {message}", flush=True)

    built = prebuild_starters(progress=log)
    seconds = time.perf_counter() - started
    print(f"starter databases built: {', '.join(built) or 'none (all cached)'} in {seconds:.0f} s")
