"""The environment map behind ``RenderOptions(method="envmap")`` and ``refsoft render --method
envmap``: options, refusals, outputs, and compare against the truth."""

import json

import numpy as np
import pytest

from refsoft import cli
from refsoft.errors import RefsoftError
from refsoft.frame import RenderOptions


def test_options():
    o = RenderOptions(method="envmap", envmap_resolution=64)
    assert o.as_dict() == {"method": "envmap", "precision": "float32", "envmap_resolution": 64}
    assert RenderOptions(**o.as_dict()) == o
    assert RenderOptions(method="envmap").envmap_resolution == 256
    with pytest.raises(RefsoftError, match="envmap_resolution applies to method='envmap' only"):
        RenderOptions(envmap_resolution=64)
    with pytest.raises(RefsoftError, match="envmap_resolution"):
        RenderOptions(method="envmap", envmap_resolution=0)
    with pytest.raises(RefsoftError, match="ldt_tau applies to method='ldt' only"):
        RenderOptions(method="envmap", ldt_tau=1.0)


def test_cli_render_and_compare(tmp_path, capsys):
    out, truth = tmp_path / "o", tmp_path / "t"
    size = ["--width", "64", "--height", "48"]
    assert cli.main(["render", "balls", "--method", "envmap", "--refine"] + size + ["--out", str(out)]) == 2
    assert "--refine is an option of the vertex search" in capsys.readouterr().err
    assert cli.main(["render", "balls", "--method", "envmap", "--envmap-resolution", "64", "--frames", "2"] + size
                    + ["--out", str(out)]) == 0
    assert "method envmap" in capsys.readouterr().out
    stats = json.loads((out / "stats.json").read_text())
    assert stats["options"] == {"method": "envmap", "precision": "float32", "envmap_resolution": 64}
    assert stats["summary"]["envmap_hits"] > 0
    with np.load(out / "frame_0000.npz") as z:
        on = z["object_id"] == 1  # the mirror ball: every pixel looks a texel up
        assert np.all(z["envmap_face"][on] >= 0) and np.all(z["envmap_face"][~on] == -1)
        assert np.all(z["envmap_texel"][~on] == -1) and z["envmap_color_1"].shape == (6, 64, 64, 3)
    assert cli.main(["truth", "balls", "--frames", "2"] + size + ["--out", str(truth)]) == 0
    assert cli.main(["compare", str(out), str(truth), "--out", str(tmp_path / "c")]) == 0
    report = json.loads((tmp_path / "c" / "metrics.json").read_text())
    # the two balls are close to the mirror: the map's parallax shows, but most pixels agree
    assert 0.0 < report["summary"]["reflected_id_disagreement"] < 0.3
