"""The pieces the apps share: a safe drop-down, the output folder, counted nouns."""

import pytest

from fluidnb.widgets._common import Choice, output_dir, plural, shown_path


def test_set_options_is_one_pick_never_the_first_option():
    c = Choice(options=["stream", "clouds"], value="clouds")
    picks, seen = [], []
    c.on_pick(picks.append)
    c.observe(lambda ch: seen.append(ch["new"]), "value")
    c.set_options(["stream", "clouds", "upload"], "upload")
    assert (c.value, picks) == ("upload", ["upload"])
    # A plain observer of value may see the passing reset; on_pick never does.
    assert seen[-1] == "upload"
    c.set_options(["stream", "clouds"], "clouds")
    assert picks == ["upload", "clouds"]
    c.set_options(["clouds", "stream"])  # the value stays when it is still offered
    assert c.value == "clouds"
    assert picks == ["upload", "clouds"]
    c.value = "stream"  # a pick from code (or the user) is a pick
    assert picks[-1] == "stream"


def test_set_options_refuses_a_value_it_does_not_offer_and_keeps_its_state():
    c = Choice(options=[("water (starter)", "water"), ("smoke (starter)", "smoke")], value="smoke")
    with pytest.raises(ValueError, match="'fire' is not among the options"):
        c.set_options([("water (starter)", "water")], "fire")
    assert c.value == "smoke"
    assert len(c.options) == 2
    c.set_options([("given", "given"), *c.options], "given")
    assert (c.value, c.label) == ("given", "given")


def test_a_plain_dropdown_would_pick_its_first_option():
    # The behaviour Choice exists for: if ipywidgets stops resetting the value, the
    # helper may go (this test then tells).
    import ipywidgets as W

    d = W.Dropdown(options=["stream", "clouds"], value="clouds")
    seen = []
    d.observe(lambda ch: seen.append(ch["new"]), "value")
    d.options = ["stream", "clouds", "upload"]
    assert seen == ["stream"]


def test_output_dir_is_beside_the_notebook_or_where_the_environment_says(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("FLUIDNB_OUTPUT_DIR", raising=False)
    assert output_dir(create=False) == tmp_path.joinpath("fluidnb-output").relative_to(tmp_path)
    assert not (tmp_path / "fluidnb-output").exists()
    assert output_dir().is_dir()
    assert shown_path(tmp_path / "fluidnb-output" / "a.gif") == "fluidnb-output/a.gif"
    monkeypatch.setenv("FLUIDNB_OUTPUT_DIR", str(tmp_path / "elsewhere"))
    assert output_dir() == tmp_path / "elsewhere"


def test_plural():
    assert [plural(n, "stroke") for n in (0, 1, 2)] == ["0 strokes", "1 stroke", "2 strokes"]
