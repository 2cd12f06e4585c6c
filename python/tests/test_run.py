"""Runs from Python against the command line: the same bytes, the same trajectory; callbacks and
Ctrl-C stop a run cleanly."""
import json
import os
import pathlib
import signal
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import raycloth

# Wall-clock figures: they differ between any two runs.
WALL_CLOCK = {"timing.json", "summary.png"}


def files_of(folder):
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(pathlib.Path(folder).rglob("*")) if p.is_file()}


def obj_vertices(path):
    rows = [line.split()[1:4] for line in pathlib.Path(path).read_text().splitlines() if line.startswith("v ")]
    return np.array(rows, dtype=np.float64).astype(np.float32)


def run_cli(cli, *args):
    return subprocess.run([cli, *map(str, args)], capture_output=True, text=True, timeout=120)


def test_run_scene_writes_the_same_bytes_as_the_cli(cli, small_scene, tmp_path):
    scene_file = tmp_path / "small.json"
    scene_file.write_text(json.dumps(small_scene))
    r = run_cli(cli, "run", scene_file, "--out", tmp_path / "cli", "--format", "obj,ply,pc2,glb", "--quiet")
    assert r.returncode == 0, r.stderr
    report = raycloth.run_scene(scene_file, tmp_path / "py", formats=["obj", "ply", "pc2", "glb"])
    a, b = files_of(tmp_path / "cli"), files_of(tmp_path / "py")
    assert sorted(a) == sorted(b)
    # 8 frames (0 and 7 of 83 steps, the last one 2) of cloth and obstacles, obj and ply; 7 more files.
    assert len(a) == 2 * 8 * 2 + 7
    for name in sorted(set(a) - WALL_CLOCK):
        assert a[name] == b[name], name
    assert report["steps"] == 500 and len(report["frames"]) == 8
    assert report["check"]["bad_frames"] == 0 and report["check"]["frames_checked"] == 8


def test_simulator_steps_the_trajectory_the_cli_writes(cli, small_scene, tmp_path):
    scene_file = tmp_path / "small.json"
    scene_file.write_text(json.dumps(small_scene))
    r = run_cli(cli, "run", scene_file, "--out", tmp_path / "cli", "--quiet")
    assert r.returncode == 0, r.stderr
    sim = raycloth.Simulator(scene_file)
    steps_per_frame = round(1 / (30 * 0.0004))  # 83
    for frame in range(8):
        if frame:
            sim.step(min(steps_per_frame, 500 - sim.steps))
        # The OBJ frames hold float32 coordinates with 12 significant digits: exactly.
        cloth = obj_vertices(tmp_path / "cli" / "frames" / f"cloth_{frame:04d}.obj")
        np.testing.assert_array_equal(sim.positions, cloth)
        obstacles = obj_vertices(tmp_path / "cli" / "frames" / f"obstacles_{frame:04d}.obj")
        np.testing.assert_array_equal(sim.obstacle_vertices(), obstacles)
    assert sim.steps == 500


def test_a_raising_callback_stops_the_run_cleanly(cli, small_scene, tmp_path):
    class Stop(Exception):
        pass

    seen = []

    def on_frame(frame):
        seen.append((frame.index, frame.step, frame.positions.shape, frame.crossings))
        if frame.index == 2:
            raise Stop("enough")

    out = tmp_path / "out"
    with pytest.raises(Stop, match="enough"):
        raycloth.run_scene(small_scene, out, formats=["obj", "pc2"], on_frame=on_frame, checkpoint_every=1)
    assert seen == [(0, 0, (225, 3), 0), (1, 83, (225, 3), 0), (2, 166, (225, 3), 0)]
    names = set(files_of(out))
    # The frames so far, whole; no temporary file, no checkpoint; run.json names the stop.
    assert {n for n in names if n.startswith("frames/cloth_")} == {f"frames/cloth_{i:04d}.obj" for i in range(3)}
    assert not [n for n in names if n.endswith(".tmp")] and "checkpoint.bin" not in names
    run = json.loads((out / "run.json").read_text())
    assert len(run["frames"]) == 3 and run["steps"] == 166
    assert run["error"].startswith("stopped by the caller at step 166 (t = 0.0664 s): ") and "enough" in run["error"]
    pc2 = (out / "cloth.pc2").read_bytes()
    assert int.from_bytes(pc2[28:32], "little") == 3 and len(pc2) == 32 + 3 * 225 * 12
    # The folder is a valid output folder: `raycloth check` takes it.
    r = run_cli(cli, "check", out, "--quiet")
    assert r.returncode == 0, r.stderr


CTRL_C_CHILD = textwrap.dedent("""
    import signal, sys
    import raycloth
    signal.signal(signal.SIGINT, signal.default_int_handler)  # even where the parent ignores SIGINT
    scene = {scene}
    what = sys.argv[1]
    if what == "step":
        sim = raycloth.Simulator(scene)
        print("stepping", flush=True)
        try:
            sim.step(10**7)
        except KeyboardInterrupt:
            print("interrupted", sim.steps, sim.positions.shape, flush=True)
            sys.exit(42)
    else:
        scene["time"]["duration"] = 1000.0
        print("stepping", flush=True)
        try:
            raycloth.run_scene(scene, sys.argv[2], formats=["pc2"])
        except KeyboardInterrupt:
            print("interrupted", flush=True)
            sys.exit(42)
    sys.exit(1)
""")


@pytest.mark.parametrize("what", ["step", "run_scene"])
def test_ctrl_c_raises_keyboard_interrupt(small_scene, tmp_path, what):
    script = tmp_path / "child.py"
    script.write_text(CTRL_C_CHILD.format(scene=repr(small_scene)))
    out = tmp_path / "out"
    child = subprocess.Popen([sys.executable, str(script), what, str(out)], stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True, env=os.environ)
    try:
        assert child.stdout.readline().strip() == "stepping"
        # Some steps in (the Simulator is built, the run has started).
        import time
        time.sleep(1.0)
        child.send_signal(signal.SIGINT)
        stdout, stderr = child.communicate(timeout=20)
    finally:
        if child.poll() is None:
            child.kill()
    assert child.returncode == 42, stderr
    assert stdout.startswith("interrupted")
    if what == "step":
        steps = int(stdout.split()[1])
        assert 0 < steps < 10**7
    else:
        run = json.loads((out / "run.json").read_text())
        assert "KeyboardInterrupt" in run["error"]
        assert not (out / "checkpoint.bin").exists() and (out / "cloth.pc2").exists()
