"""Octree.render: the same image as svo-view --cpu, and its per-pixel outputs."""

import subprocess

import numpy as np
import pytest
from PIL import Image

import svo
from conftest import program


@pytest.mark.parametrize(
    "flags, kwargs",
    [
        ([], {}),
        (["--eye", "3,2,4", "--fov", "30", "--hit", "cube", "--shadows", "opaque"],
         {"eye": (3, 2, 4), "fov": 30, "mode": "cube", "shadows": "opaque"}),
    ],
)
def test_the_same_image_as_svo_view(tmp_path, torus, flags, kwargs):
    tree = svo.bake(torus, depth=6)
    path = tmp_path / "t.svo"
    tree.save(path)
    png = tmp_path / "t.png"
    subprocess.run(
        [program("svo-view"), path, "--cpu", "--size", "96x64", "-o", png, *flags],
        check=True,
        capture_output=True,
    )
    expected = np.asarray(Image.open(png).convert("RGB"))
    image = tree.render(96, 64, **kwargs)
    assert image.shape == (64, 96, 3) and image.dtype == np.uint8
    np.testing.assert_array_equal(image, expected)


def test_aovs(torus):
    tree = svo.bake(torus, depth=6)
    a = tree.render_aovs(80, 60)
    hit = a["leaf"] >= 0
    assert 0 < hit.sum() < 80 * 60
    assert np.isinf(a["depth"][~hit]).all() and np.isfinite(a["depth"][hit]).all()
    assert (a["normal"][~hit] == 0).all()
    np.testing.assert_allclose(np.linalg.norm(a["normal"][hit], axis=-1), 1, atol=1e-3)
    assert (a["cost"][hit] > 0).all() and a["colour"].dtype == np.float32
    # the image is the colour output in sRGB
    image = tree.render(80, 60)
    assert image[hit].mean() > 0 and image.shape == a["colour"].shape
    # threads and lod 0 change nothing
    np.testing.assert_array_equal(tree.render(80, 60, threads=1), image)
