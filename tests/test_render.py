"""Pictures: SurfaceMesh.render writes a readable PNG of the requested size."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

mpimg = pytest.importorskip("matplotlib.image")

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def read_png(path) -> np.ndarray:
    """The picture as an (H, W, 4) float array, after checking the PNG signature."""
    with open(path, "rb") as fh:
        assert fh.read(8) == PNG_SIGNATURE
    return mpimg.imread(path)


def is_background(pixel: np.ndarray) -> bool:
    return bool(np.all(pixel[:3] > 0.97))


def covered(img: np.ndarray) -> np.ndarray:
    """Pixels that are not the white background, (H, W) bool."""
    return ~np.all(img[..., :3] > 0.97, axis=-1)


def widest_interior_gap(mask: np.ndarray) -> int:
    """Longest run of background pixels between drawn pixels, over the rows."""
    best = 0
    for row in mask:
        idx = np.nonzero(row)[0]
        if len(idx) < 2:
            continue
        run = 0
        for v in row[idx[0] : idx[-1] + 1]:
            run = 0 if v else run + 1
            best = max(best, run)
    return best


def test_render_sphere(sphere_case, tmp_path):
    path = tmp_path / "sphere.png"
    sphere_case.mesh.render(path, size=240)
    img = read_png(path)
    assert img.shape == (240, 240, 4)
    rgb, mask = img[..., :3], covered(img)
    # Not a blank picture: the sphere in the middle, background in the corners,
    # one solid disc, shading with many different colours.
    assert mask[120, 120]
    assert not mask[:3, :3].any() and not mask[-3:, -3:].any()
    assert 0.2 < mask.mean() < 0.9
    assert widest_interior_gap(mask) == 0
    assert len(np.unique(np.round(rgb[mask], 2), axis=0)) > 20
    # Lit from the upper left: that quarter is brighter than the lower right.
    ys, xs = np.nonzero(mask)
    cy, cx = ys.mean(), xs.mean()
    lum = rgb.mean(axis=-1)
    upper_left = (ys < cy) & (xs < cx)
    lower_right = (ys > cy) & (xs > cx)
    assert (
        lum[ys[upper_left], xs[upper_left]].mean() > lum[ys[lower_right], xs[lower_right]].mean()
    )


def test_torus_picture_shows_the_hole(torus_case, tmp_path):
    path = tmp_path / "torus.png"
    torus_case.mesh.render(path, size=300)
    mask = covered(read_png(path))
    # Seen from 25 degrees above, the background shows through the hole.
    assert widest_interior_gap(mask) >= 0.05 * 300


def test_render_size_and_title(sphere_case, tmp_path):
    small, big = tmp_path / "small.png", tmp_path / "big.png"
    sphere_case.mesh.render(small, size=100, title="sphere")
    sphere_case.mesh.render(big, size=333)
    assert read_png(small).shape[:2] == (100, 100)
    assert read_png(big).shape[:2] == (333, 333)
    # The title is drawn above the mesh: ink in the top rows only with a title.
    assert covered(read_png(small))[:12].any()
    assert not covered(read_png(big))[:12].any()


def test_empty_mesh_gives_a_picture(tmp_path):
    from rdmesh.io.render import render

    path = tmp_path / "empty.png"
    render(np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64), path, size=64)
    assert read_png(path).shape[:2] == (64, 64)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"size": 0}, "size must be"),
        ({"size": 2.5}, "size must be"),
        ({"size": True}, "size must be"),
        ({"faces": np.array([[0, 1, 9]])}, "do not exist"),
        ({"faces": np.array([0, 1, 2])}, r"faces must have shape \(M, 3\)"),
        ({"vertices": np.zeros((3, 2))}, r"vertices must have shape \(N, 3\)"),
    ],
)
def test_bad_render_arguments(kwargs, match, tmp_path):
    from rdmesh.io.render import render

    args = {"vertices": np.eye(3), "faces": np.array([[0, 1, 2]]), "size": 64} | kwargs
    with pytest.raises(ValueError, match=match):
        render(path=tmp_path / "x.png", **args)
    assert not (tmp_path / "x.png").exists()


def test_render_is_headless_and_leaves_pyplot_alone(tmp_path):
    # In a fresh interpreter without a display: no pyplot import, no backend switch.
    code = (
        "import sys, numpy as np\n"
        "from rdmesh.io.render import render\n"
        "render(np.eye(3), np.array([[0, 1, 2]]), sys.argv[1], size=32)\n"
        "print('matplotlib.pyplot' in sys.modules)\n"
    )
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "MPLBACKEND")}
    out = subprocess.run(
        [sys.executable, "-c", code, str(tmp_path / "t.png")],
        capture_output=True,
        text=True,
        env=env,
        timeout=60,
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "False"
    assert read_png(tmp_path / "t.png").shape[:2] == (32, 32)
