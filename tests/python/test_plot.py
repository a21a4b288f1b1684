"""Pictures: the SVG lobe plot draws for the same request, shown inline and saved."""

import subprocess

import pytest

import lobe
import lobe.plot


@pytest.mark.parametrize("kind", ["polar", "hemisphere", "albedo"])
def test_a_figure_is_the_picture_lobe_plot_draws(lobe_bin, tmp_path, gpu, kind):
    out = tmp_path / "cli.svg"
    done = subprocess.run([lobe_bin, "plot", "--kind", kind, "--model", "cook_torrance",
                           "--material", "gold", "-o", str(out)], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr
    figure = getattr(lobe.plot, kind)(gpu, "cook_torrance", material="gold")
    assert figure._repr_svg_() == out.read_text()
    png = figure._repr_png_()
    assert png.startswith(b"\x89PNG\r\n\x1a\n")
    figure.save(tmp_path / "py.png")
    assert (tmp_path / "py.png").read_bytes() == png
    assert "cook_torrance" in repr(figure)


def test_plot_refusals(gpu):
    with pytest.raises(ValueError, match="theta_i_deg.*95.*\\[0, 90\\)"):
        lobe.plot.polar(gpu, "lambert", theta_i_deg=[95])
    with pytest.raises(ValueError, match="channel"):
        lobe.plot.polar(gpu, "lambert", channel="alpha")
    with pytest.raises(TypeError, match="session"):
        lobe.plot.polar("gpu", "lambert")
