"""The command line, run as a subprocess: files written, exit codes, messages.

Each run is small (about a second, most of it start-up).
"""

from __future__ import annotations

import io
import os
import re
import signal
import subprocess
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
import rdmesh
import trimesh
from rdmesh import cli
from rdmesh.progress import ProgressBar
from rdmesh.surfaces import SURFACES
from test_render import covered, read_png


def run(*args: str, cwd=None, timeout: float = 120) -> subprocess.CompletedProcess:
    """``python -m rdmesh ARGS`` in ``cwd``; text output captured."""
    env = dict(os.environ)
    env.pop("PYTHONWARNINGS", None)
    return subprocess.run(
        [sys.executable, "-m", "rdmesh", *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=timeout,
        env=env,
    )


def load(path, merge: bool = False) -> trimesh.Trimesh:
    mesh = trimesh.load(path, process=merge, force="mesh")
    assert isinstance(mesh, trimesh.Trimesh)
    return mesh


# -- success ----------------------------------------------------------------------------


def test_mesh_builtin_with_picture(tmp_path):
    out = run(
        "mesh", "sphere", "--radius", "0.2", "-o", "out/s.ply", "--png", "pics/s.png",
        "--png-size", "320", cwd=tmp_path,
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    assert "Traceback" not in out.stderr
    mesh = load(tmp_path / "out" / "s.ply")
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert mesh.euler_number == 2
    np.testing.assert_allclose(np.linalg.norm(mesh.vertices, axis=1), 1.0, atol=1e-6)
    img = read_png(tmp_path / "pics" / "s.png")
    assert img.shape == (320, 320, 4)
    mask = covered(img)
    assert mask[160, 160] and 0.1 < mask.mean() < 0.9
    assert len(np.unique(np.round(img[..., :3][mask], 2), axis=0)) > 10
    # The summary on stdout.
    assert "sphere: wrote out/s.ply and pics/s.png" in out.stdout
    assert f"vertices {len(mesh.vertices)}, faces {len(mesh.faces)}" in out.stdout
    assert "closed manifold: yes" in out.stdout


@pytest.mark.parametrize("ext", ["ply", "obj", "stl", "off", "glb"])
def test_formats_by_extension(ext, tmp_path):
    out = run("mesh", "torus", "--radius", "0.1", "-o", f"t.{ext}", "--quiet", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    # STL stores triangles, not shared vertices: merge them back to count.
    mesh = load(tmp_path / f"t.{ext}", merge=ext == "stl")
    assert mesh.is_watertight
    assert mesh.euler_number == 0
    m = re.search(r"vertices (\d+), faces (\d+)", out.stdout)
    assert (len(mesh.vertices), len(mesh.faces)) == (int(m[1]), int(m[2]))


def test_quiet_success_writes_nothing_on_stderr(tmp_path):
    out = run("mesh", "torus", "--radius", "0.1", "-o", "t.ply", "--quiet", cwd=tmp_path)
    assert out.returncode == 0
    assert out.stderr == ""
    assert "torus: wrote t.ply" in out.stdout
    assert re.search(r"vertices \d+, faces \d+", out.stdout)
    assert "components 1 (genus 1)" in out.stdout


def test_expression_with_bound(tmp_path):
    out = run(
        "mesh", "x**2 + y**2 + z**2 - 1", "--bound", "2", "--radius", "0.2", "-o", "e.off",
        "--quiet", cwd=tmp_path,
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    mesh = load(tmp_path / "e.off")
    assert mesh.is_watertight and mesh.euler_number == 2
    np.testing.assert_allclose(np.linalg.norm(mesh.vertices, axis=1), 1.0, atol=1e-6)


def test_expression_with_sphere(tmp_path):
    # A torus about (1, 0, 0), in a sphere given with a negative coordinate.
    text = "(sqrt((x - 1)**2 + y**2) - 1)**2 + z**2 - 0.16"
    out = run(
        "mesh", text, "--sphere=1,0,-0.0,1.6", "--radius", "0.08", "-o", "t.ply", "--quiet",
        cwd=tmp_path,
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    mesh = load(tmp_path / "t.ply")
    assert mesh.is_watertight and mesh.euler_number == 0
    np.testing.assert_allclose(mesh.vertices.mean(axis=0), [1, 0, 0], atol=0.02)


def test_bound_overrides_a_builtin_sphere(tmp_path):
    # The built-in sphere has bounding radius 2: the default radius bound is 2/20;
    # --bound 4 doubles it, so the mesh has about a quarter of the vertices.
    a = run("mesh", "sphere", "-o", "a.ply", "--quiet", cwd=tmp_path)
    b = run("mesh", "sphere", "--bound", "4", "-o", "b.ply", "--quiet", cwd=tmp_path)
    assert a.returncode == b.returncode == 0
    na, nb = len(load(tmp_path / "a.ply").vertices), len(load(tmp_path / "b.ply").vertices)
    assert 2.5 < na / nb < 6


def test_list_shows_every_builtin_surface():
    out = run("list")
    assert out.returncode == 0 and out.stderr == ""
    lines = out.stdout.splitlines()
    assert [line.split()[0] for line in lines] == list(SURFACES)


def test_demo_writes_mesh_and_picture(tmp_path):
    out = run("demo", "--surface", "torus", "--quiet", "--png-size", "200", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert out.stderr == ""
    mesh = load(tmp_path / "out" / "demo.ply")
    assert mesh.is_watertight and mesh.euler_number == 0
    assert read_png(tmp_path / "out" / "demo.png").shape == (200, 200, 4)
    # The demo meshes the expression form with proofs: the summary says so.
    out = run("demo", "--surface", "sphere", "--png-size", "100", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert "topological ball property: certified" in out.stdout


def test_verbose_logs_on_stderr(tmp_path):
    out = run("mesh", "sphere", "--radius", "0.2", "-o", "s.ply", "-v", cwd=tmp_path)
    assert out.returncode == 0
    assert "rdmesh: meshing sphere" in out.stderr
    assert "Traceback" not in out.stderr


def test_version():
    out = run("--version")
    assert out.returncode == 0
    assert out.stdout.startswith(f"rdmesh {rdmesh.__version__} (CGAL ")


# -- errors: exit 2, one line, no traceback, nothing written -----------------------------

ERRORS = [
    (["mesh", "sphree", "-o", "x.ply"], r"unknown surface 'sphree'"),
    (["demo", "--surface", "nope", "-o", "x.ply", "--png", "x.png"], r"unknown surface 'nope'"),
    (["mesh", "os.system('ls')", "--bound", "2", "-o", "x.ply"], r"attribute access"),
    (["mesh", "__import__('os')", "--bound", "2", "-o", "x.ply"], r"unknown function"),
    (["mesh", "x**2 + w", "--bound", "2", "-o", "x.ply"], r"unknown name 'w'"),
    (["mesh", "x**2 +", "--bound", "2", "-o", "x.ply"], r"syntax error"),
    (["mesh", "x**2 + y**2 + z**2 - 1", "-o", "x.ply"], r"needs a bounding sphere"),
    (["mesh", "x +* 2", "-o", "x.ply"], r"syntax error: invalid syntax \(column 4\)"),
    (["mesh", "x**2 + y**2 + z**2 - 1", "--bound", "0.5", "-o", "x.ply"], r"bounding sphere"),
    (["mesh", "sqrt(x)", "--bound", "1", "-o", "x.ply"], r"returned nan"),
    (["mesh", "sphere", "--bound", "2", "--sphere", "0,0,0,2", "-o", "x.ply"], r"not allowed"),
    (["mesh", "sphere", "--sphere", "1,2", "-o", "x.ply"], r"expected cx,cy,cz,R"),
    (["mesh", "sphere", "--sphere", "0,0,0,-1", "-o", "x.ply"], r"must be positive"),
    (["mesh", "sphere", "--angle", "45", "-o", "x.ply"], r"between 0 and 30"),
    (["mesh", "sphere", "--radius", "-1", "-o", "x.ply"], r"must be positive"),
    (["mesh", "sphere", "--radius", "abc", "-o", "x.ply"], r"not a number"),
    (["mesh", "sphere", "--distance", "nan", "-o", "x.ply"], r"must be finite"),
    (["mesh", "sphere", "--max-vertices", "0", "-o", "x.ply"], r"at least 1"),
    (["mesh", "sphere", "--time-limit", "0", "-o", "x.ply"], r"must be positive"),
    (["mesh", "sphere", "--seed", "x", "-o", "x.ply"], r"invalid int value"),
    (["mesh", "sphere", "--method", "magic", "-o", "x.ply"], r"invalid choice"),
    (["mesh", "sphere", "--topology", "knot", "-o", "x.ply"], r"invalid choice"),
    (["mesh", "sphere", "--png-size", "5", "-o", "x.ply"], r"between 16 and 10000"),
    (["mesh", "z", "--clip-box", "0", "0", "0", "1", "1", "-o", "x.ply"], r"expected 6 arguments"),
    (["mesh", "z", "--clip-box", "0", "0", "0", "1", "nan", "1", "-o", "x.ply"], r"finite: 'nan'"),
    (["mesh", "z", "--clip-box", "0", "1", "0", "1", "1", "1", "-o", "x.ply"], r"not on y$"),
    (
        ["mesh", "z", "--bound", "1", "--clip-box", "0", "0", "0", "1", "1", "1", "-o", "x.ply"],
        r"clip box .* must lie inside its bounding sphere",
    ),
    (["mesh", "sphere", "-o", "x.xyz"], r"unknown mesh format 'xyz'"),
    (["mesh", "sphere", "-o", "x.ply", "--png", "x.jpg"], r"must end in .png"),
    (["mesh", "sphere", "-o", "afile/x.ply"], r"cannot create folder"),
    (["mesh", "sphere", "-o", "adir.ply"], r"it is a folder"),
    (["mesh", "sphere"], r"required: -o/--output"),
    (["mesh", "sphere", "-o", "x.ply", "--frobnicate"], r"unrecognized arguments"),
    ([], r"required: command"),
    (["magic"], r"invalid choice"),
]


#: One case of each kind also runs as a subprocess (start-up costs most of a
#: second each); every case runs in-process through ``cli.main``.
SUBPROCESS_ERRORS = [
    "unknown surface 'sphree'",
    "attribute access",
    "unknown function",
    "syntax error",
    "needs a bounding sphere",
    "returned nan",
    "between 0 and 30",
    "invalid choice",
    "unknown mesh format 'xyz'",
    "cannot create folder",
    "it is a folder",
    "required: command",
]
assert set(SUBPROCESS_ERRORS) <= {m for _, m in ERRORS}


def _error_dir(path):
    (path / "afile").write_text("not a folder")
    (path / "adir.ply").mkdir()
    return sorted(p.name for p in path.iterdir())


def _check_error(status: int, stdout: str, stderr: str, match: str) -> None:
    assert status == 2, stderr
    assert "Traceback" not in stderr
    lines = stderr.splitlines()
    assert len(lines) == 1, stderr
    assert lines[0].startswith("rdmesh: error: ")
    assert re.search(match, lines[0]), lines[0]
    assert stdout == ""


@pytest.fixture(scope="module")
def error_runs(tmp_path_factory) -> dict:
    """The subprocess error cases, run a few at a time."""

    def one(match: str):
        cwd = tmp_path_factory.mktemp("error")
        before = _error_dir(cwd)
        args = next(a for a, m in ERRORS if m == match)
        out = run(*args, cwd=cwd)
        return out, before, sorted(p.name for p in cwd.iterdir())

    with ThreadPoolExecutor(max_workers=4) as pool:
        return dict(zip(SUBPROCESS_ERRORS, pool.map(one, SUBPROCESS_ERRORS), strict=True))


@pytest.mark.parametrize("match", SUBPROCESS_ERRORS)
def test_errors_exit_2_with_one_line(match, error_runs):
    out, before, after = error_runs[match]
    _check_error(out.returncode, out.stdout, out.stderr, match)
    assert after == before  # nothing written


@pytest.mark.parametrize(("args", "match"), ERRORS, ids=[m for _, m in ERRORS])
def test_errors_in_process(args, match, tmp_path, capsys, monkeypatch):
    before = _error_dir(tmp_path)
    monkeypatch.chdir(tmp_path)
    status = cli.main(args)
    captured = capsys.readouterr()
    _check_error(status, captured.out, captured.err, match)
    assert sorted(p.name for p in tmp_path.iterdir()) == before


# -- budgets and Ctrl-C ----------------------------------------------------------------


def test_max_vertices_writes_the_partial_mesh(tmp_path):
    out = run(
        "mesh", "torus", "--radius", "0.05", "--max-vertices", "300", "-o", "p.ply",
        "--png", "p.png", "--png-size", "64", "--quiet", cwd=tmp_path,
    )  # fmt: skip
    assert out.returncode == 1
    assert "Traceback" not in out.stderr
    assert out.stderr.splitlines() == [
        "rdmesh: stopped early (max_vertices=300 reached); "
        "wrote the partial mesh to p.ply and p.png"
    ]
    assert "INCOMPLETE" in out.stdout
    mesh = load(tmp_path / "p.ply")
    assert len(mesh.faces) > 0 and len(mesh.vertices) <= 300
    assert read_png(tmp_path / "p.png").shape[:2] == (64, 64)


def test_time_limit_writes_the_partial_mesh(tmp_path):
    out = run(
        "mesh", "sphere", "--radius", "0.01", "--time-limit", "0.001", "-o", "p.obj",
        "--quiet", cwd=tmp_path,
    )  # fmt: skip
    assert out.returncode == 1
    assert re.fullmatch(
        r"rdmesh: stopped early \(time_limit=.*\); wrote the partial mesh to p\.obj\n",
        out.stderr,
    )
    assert len(load(tmp_path / "p.obj").faces) > 0


def _default_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _interrupt_after_first_round(tmp_path, *gaps: float):
    """Run a minute-long mesh job, and once refinement rounds have begun (the
    progress bar, on stderr after a second, shows the round) send SIGINT, and
    again after each of ``gaps`` seconds. Returns (status, stdout, stderr).

    The watchdog only guards against a hang: it aborts rdmesh, whose fault
    handler then writes every thread's stack to stderr (the failure shows where
    it hung), which ends the read loop and fails the test on the exit status.
    """
    proc = subprocess.Popen(
        [sys.executable, "-X", "faulthandler", "-m", "rdmesh", "mesh", "torus",
         "--radius", "0.004", "--time-limit", "3600", "-o", "int.ply"],
        cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        # A shell's background job ignores SIGINT, and so would rdmesh (Python
        # keeps an inherited SIG_IGN): give it the default, as in a terminal.
        preexec_fn=_default_sigint,
    )  # fmt: skip
    watchdog = threading.Timer(900, proc.send_signal, (signal.SIGABRT,))
    watchdog.daemon = True
    watchdog.start()
    try:
        seen = b""
        while not re.search(rb"round=\d", seen):
            chunk = os.read(proc.stderr.fileno(), 4096)
            assert chunk, f"rdmesh ended before the first round was shown: {seen!r}"
            seen += chunk
        proc.send_signal(signal.SIGINT)
        for gap in gaps:
            time.sleep(gap)
            proc.send_signal(signal.SIGINT)
        stdout, stderr = proc.communicate()
    finally:
        watchdog.cancel()
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    return proc.returncode, stdout.decode(), (seen + stderr).decode()


def test_ctrl_c_writes_the_partial_mesh(tmp_path):
    status, stdout, stderr = _interrupt_after_first_round(tmp_path)
    assert status == 130, stderr
    assert "Traceback" not in stderr
    assert stderr.rstrip().splitlines()[-1] == (
        "rdmesh: interrupted; wrote the partial mesh to int.ply"
    )
    assert "INCOMPLETE: interrupted" in stdout
    # Refinement had passed round 1 (over 6000 samples): the partial mesh is
    # what was there, not a stub.
    mesh = load(tmp_path / "int.ply")
    assert len(mesh.faces) >= 1000
    assert f"vertices {len(mesh.vertices)}, faces {len(mesh.faces)}" in stdout


@pytest.mark.parametrize("gap", [0.0, 0.02, 0.2])
def test_two_ctrl_c_end_with_status_130(gap, tmp_path):
    """A second Ctrl-C used to interrupt the worker's shutdown while the core
    was still in use (a segfault). Now it must end with status 130."""
    status, _, stderr = _interrupt_after_first_round(tmp_path, gap)
    assert status == 130, stderr[-8000:]
    assert "Traceback" not in stderr


# -- the progress bar ----------------------------------------------------------------------


def _feed(bar: ProgressBar, rounds: int, pause: float) -> None:
    for r in range(1, rounds + 1):
        bar.update(
            {"round": r, "stage": "facet", "inserted": 10, "vertices": 100 * r, "seconds": 0}
        )
        time.sleep(pause)


def test_progress_bar_hidden_for_short_runs():
    out = io.StringIO()
    with ProgressBar(file=out, delay=5.0) as bar:
        _feed(bar, 3, 0.05)
    assert out.getvalue() == ""


def test_progress_bar_shows_rounds_vertices_and_stage():
    out = io.StringIO()
    with ProgressBar(file=out, delay=0.2) as bar:
        _feed(bar, 4, 0.1)
    text = out.getvalue()
    assert text.endswith("\n")
    final = text.rstrip("\n").split("\r")[-1]
    assert re.fullmatch(r"rdmesh: 400 vertices \[\d\d:\d\d, round=4, stage=facet\] *", final)
    # With a vertex budget the bar shows the fraction.
    out = io.StringIO()
    with ProgressBar(total=800, file=out, delay=0.0) as bar:
        _feed(bar, 2, 0.05)
    assert "25%" in out.getvalue() or "50%" in out.getvalue()
    assert "200/800 vertices" in out.getvalue()


def test_progress_bar_keeps_log_records_on_their_own_lines(monkeypatch):
    # The bar writes log records above itself for console handlers (stderr).
    out = io.StringIO()
    monkeypatch.setattr(sys, "stderr", out)
    logger = logging_setup(out)
    try:
        with ProgressBar(file=out, delay=0.0) as bar:
            _feed(bar, 1, 0.1)
            logger.warning("a warning")
            _feed(bar, 1, 0.1)
    finally:
        logger.handlers.clear()
    lines = out.getvalue().split("\n")
    assert any(line.split("\r")[-1].strip() == "a warning" for line in lines)


def logging_setup(stream):
    import logging

    logger = logging.getLogger("rdmesh")
    logger.handlers.clear()
    logger.addHandler(logging.StreamHandler(stream))
    return logger


def test_api_progress_is_off_by_default(capfd):
    surface = SURFACES["sphere"].make()
    rdmesh.mesh_surface(surface, radius_bound=0.3)
    captured = capfd.readouterr()
    assert captured.out == "" and captured.err == ""


def test_api_progress_true_shows_a_bar_on_stderr(capfd, monkeypatch):
    # A surface that takes over a second: each evaluation is slowed down.
    base = SURFACES["sphere"].make()

    def slow(p):
        time.sleep(0.06)
        return base.f(p)

    surface = rdmesh.ImplicitSurface(slow, base.bounding_sphere, gradient=base.gradient)
    rdmesh.mesh_surface(surface, radius_bound=0.3, progress=True)
    captured = capfd.readouterr()
    assert captured.out == ""
    assert re.search(r"rdmesh: \d+ vertices \[\d\d:\d\d, round=\d+, stage=\w+\]", captured.err)
    assert captured.err.endswith("\n")


@pytest.fixture
def without_tqdm(monkeypatch):
    """tqdm, an optional dependency, as if not installed."""
    for name in ("tqdm", "tqdm.contrib", "tqdm.contrib.logging"):
        monkeypatch.setitem(sys.modules, name, None)


def test_api_progress_true_without_tqdm_says_what_to_install(without_tqdm):
    with pytest.raises(ImportError, match=r"needs tqdm: pip install 'rdmesh\[progress\]'"):
        rdmesh.mesh_surface(SURFACES["sphere"].make(), radius_bound=0.3, progress=True)
    # Without a bar to show nothing is needed.
    with ProgressBar(disable=True) as bar:
        bar.update({"round": 1, "vertices": 10})


def test_cli_runs_without_a_bar_without_tqdm(without_tqdm, tmp_path, capsys):
    # The bar is on by default; without tqdm the run goes on without it.
    assert cli.main(["mesh", "sphere", "--radius", "0.3", "-o", str(tmp_path / "s.ply")]) == 0
    assert capsys.readouterr().err == ""
    assert (tmp_path / "s.ply").exists()


class _InterruptOnce(io.StringIO):
    """A stream whose first write of a bar raises KeyboardInterrupt (Ctrl-C mid-draw)."""

    def __init__(self) -> None:
        super().__init__()
        self.armed = True

    def write(self, s: str) -> int:
        if self.armed and "100 vertices" in s:
            self.armed = False
            raise KeyboardInterrupt
        return super().write(s)


def test_progress_bar_ends_its_line_after_ctrl_c_mid_draw():
    out = _InterruptOnce()
    with pytest.raises(KeyboardInterrupt), ProgressBar(file=out, delay=0.0) as bar:
        _feed(bar, 1, 0.0)
    assert not out.armed
    # The final state is drawn and the line ended, so the next message starts clean.
    assert out.getvalue().endswith("]\n")
    assert "100 vertices" in out.getvalue()


# -- the interrupt paths, in-process with a stand-in for mesh_surface --------------------------


def _partial_sphere():
    return rdmesh.mesh_surface(SURFACES["sphere"].make(), radius_bound=0.3)


def test_interrupted_mesh_is_written(tmp_path, capsys, monkeypatch):
    mesh = _partial_sphere()

    def interrupted(surface, **opts):
        raise rdmesh.Interrupted("refinement interrupted", mesh=mesh, reason="interrupted")

    monkeypatch.setattr(cli, "mesh_surface", interrupted)
    status = cli.main(["mesh", "sphere", "-o", str(tmp_path / "i.ply"), "--quiet"])
    captured = capsys.readouterr()
    assert status == 130
    assert captured.err == f"rdmesh: interrupted; wrote the partial mesh to {tmp_path / 'i.ply'}\n"
    assert len(load(tmp_path / "i.ply").faces) == len(mesh.faces)


@pytest.mark.parametrize(
    ("exc", "status", "message"),
    [
        (KeyboardInterrupt(), 130, "rdmesh: interrupted"),
        (rdmesh.Interrupted("x", mesh=None), 130, "rdmesh: interrupted; no mesh to write"),
        (
            rdmesh.BudgetExceeded("x", mesh=None, reason="max_vertices=5 reached"),
            1,
            "rdmesh: stopped early (max_vertices=5 reached); no mesh to write",
        ),
    ],
    ids=["seeding", "interrupted_without_mesh", "budget_without_mesh"],
)
def test_stops_without_a_mesh(exc, status, message, tmp_path, capsys, monkeypatch):
    def stop(surface, **opts):
        raise exc

    monkeypatch.setattr(cli, "mesh_surface", stop)
    assert cli.main(["mesh", "sphere", "-o", str(tmp_path / "x.ply"), "--quiet"]) == status
    assert capsys.readouterr().err == message + "\n"
    assert not (tmp_path / "x.ply").exists()


def test_failure_while_recovering_from_ctrl_c_is_still_an_interrupt(tmp_path, capsys, monkeypatch):
    def broken_recovery(surface, **opts):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt:
            raise ValueError("state lost") from None

    monkeypatch.setattr(cli, "mesh_surface", broken_recovery)
    assert cli.main(["mesh", "sphere", "-o", str(tmp_path / "x.ply"), "--quiet"]) == 130
    assert capsys.readouterr().err == "rdmesh: interrupted; no partial mesh: state lost\n"
