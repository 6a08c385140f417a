"""The oracle's own bits: every array of the golden set against the SHA-256 committed in
``tests/conformance/golden_hashes.json`` (``tests/golden_hashes.py``). A new NumPy, Numba or
llvmlite that changes one output bit fails here, by name, instead of moving the ports' reference
silently; a change of refsoft's outputs regenerates the file on purpose."""

import shutil

import numpy as np

from golden_hashes import differences, golden_hashes, read_hashes


def test_the_golden_set_has_the_committed_hashes(golden):
    import numba

    committed = read_hashes()
    diff = differences(committed["hashes"], golden_hashes(golden))
    assert not diff, (
        f"{len(diff)} of {len(committed['hashes'])} golden outputs differ from tests/conformance/golden_hashes.json "
        f"(made with numpy {committed['numpy']}, numba {committed['numba']}; this is numpy {np.__version__}, "
        f"numba {numba.__version__}). If the change is meant, regenerate it (python tests/golden_hashes.py) in the "
        "commit that changes the outputs and say why in its message. First differences:\n" + "\n".join(diff[:20]))


def test_one_changed_bit_is_named(golden, tmp_path):
    gold = tmp_path / "golden"
    shutil.copytree(golden, gold)
    npz = gold / "sphere" / "frame_0000.npz"
    with np.load(npz) as z:
        arrays = {k: z[k] for k in z.files}
    flipped = arrays["virtual_vertex_1"].copy()
    flipped.view(np.uint32)[7, 1] ^= 1  # the last bit of one float32
    np.savez_compressed(npz, **{**arrays, "virtual_vertex_1": flipped})
    before = golden_hashes(golden)
    assert differences(before, golden_hashes(gold)) == ["changed: sphere/frame_0000.npz:virtual_vertex_1"]
    (gold / "sphere" / "traces_0000.json").write_text("{}")
    assert "changed: sphere/traces_0000.json" in differences(before, golden_hashes(gold))
