"""Every error comes through as a Python exception with the command line's FILE: FIELD: REASON text."""
import json
import subprocess

import numpy as np
import pytest

import raycloth


def test_the_exception_classes():
    assert issubclass(raycloth.InputError, raycloth.Error) and issubclass(raycloth.InputError, ValueError)
    assert issubclass(raycloth.SimulationError, raycloth.Error) and issubclass(raycloth.SimulationError, RuntimeError)


def test_a_bad_scene_file_gives_the_cli_message(cli, small_scene, tmp_path):
    small_scene["panels"][0]["material"] = "silk"
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(small_scene))
    with pytest.raises(raycloth.InputError) as e:
        raycloth.Scene.from_file(path)
    assert str(e.value) == f"{path}: /panels/0/material: unknown material 'silk'"
    assert (e.value.file, e.value.field, e.value.reason) == (str(path), "/panels/0/material", "unknown material 'silk'")
    r = subprocess.run([cli, "run", str(path), "--out", str(tmp_path / "out")], capture_output=True, text=True)
    assert r.returncode == 2 and r.stderr.strip() == f"raycloth: error: {e.value}"
    # The same through run_scene and Simulator.
    for call in (lambda: raycloth.run_scene(path, tmp_path / "out2"), lambda: raycloth.Simulator(path)):
        with pytest.raises(raycloth.InputError, match="unknown material 'silk'"):
            call()
    assert not (tmp_path / "out2").exists()


def test_a_missing_file_text_and_dict_errors(small_scene, tmp_path):
    with pytest.raises(raycloth.InputError) as e:
        raycloth.load_scene(tmp_path / "none.json")
    assert e.value.file == str(tmp_path / "none.json") and str(e.value).startswith(str(tmp_path / "none.json") + ": ")
    with pytest.raises(raycloth.InputError) as e:
        raycloth.Scene.from_json("{ not json", origin="mine.json")
    assert e.value.file == "mine.json" and str(e.value).startswith("mine.json: ")
    small_scene["time"]["dt"] = -1
    with pytest.raises(raycloth.InputError) as e:
        raycloth.Scene.from_dict(small_scene)
    assert e.value.file == "<dict>" and e.value.field == "/time/dt"


def test_simulator_input_errors(small_scene, tmp_path):
    with pytest.raises(raycloth.InputError) as e:
        raycloth.Simulator(small_scene, device="tpu")
    assert str(e.value) == "<dict>: device: unknown device 'tpu' (expected cpu, cuda or auto)"
    small_scene["time"]["dt"] = 0.01  # above the stability limit
    with pytest.raises(raycloth.InputError) as e:
        raycloth.Simulator(small_scene)
    assert e.value.field == "/time/dt" and "or allow it explicitly" in e.value.reason
    with pytest.raises(ValueError, match="threads"):
        raycloth.Simulator(small_scene, threads=-1)


def test_a_device_that_cannot_run_or_edit(small_scene):
    ok, why = raycloth.cuda_available()
    if not ok:
        with pytest.raises(raycloth.SimulationError) as e:
            raycloth.Simulator(small_scene, device="cuda")
        assert str(e.value) == f"device 'cuda' cannot run: {why}"
        return
    # With a GPU: the CUDA backend steps, and refuses the edits (the CPU device's).
    sim = raycloth.Simulator(small_scene, device="cuda")
    sim.step(10)
    assert sim.device == "cuda" and sim.positions.shape == (225, 3)
    with pytest.raises(raycloth.SimulationError, match="set_state: not supported on the cuda backend"):
        sim.set_state(sim.positions)
    with pytest.raises(raycloth.SimulationError, match="move_obstacle: not supported on the cuda backend"):
        sim.move_obstacle(0, vertices=sim.obstacle_vertices(0))


def test_state_edit_errors(small_scene):
    sim = raycloth.Simulator(small_scene)
    with pytest.raises(ValueError, match=r"expected an array of shape \(n, 3\)"):
        sim.set_state(np.zeros((225, 2)))
    with pytest.raises(raycloth.InputError) as e:
        sim.set_state(np.zeros((10, 3)))
    assert str(e.value) == "<dict>: positions: expected 225 cloth vertices (got 10)"
    x = sim.positions.copy()
    x[7, 2] = np.nan
    with pytest.raises(raycloth.InputError, match=r"positions\[7\]: must be finite"):
        sim.set_state(x)
    with pytest.raises(raycloth.InputError, match="vertex 225 is not a cloth vertex"):
        sim.pin([225])
    with pytest.raises(raycloth.InputError, match="obstacle 'sphere' has 578 vertices"):
        sim.move_obstacle(0, vertices=np.zeros((3, 3)))
    with pytest.raises(raycloth.InputError, match="obstacle 3 does not exist"):
        sim.move_obstacle(3, vertices=np.zeros((3, 3)))
    with pytest.raises(ValueError, match="either vertices or transform"):
        sim.move_obstacle(0)


def test_a_blow_up_raises_simulation_error(small_scene, tmp_path):
    # Far past the stability limit, stretched at the start and held by a corner (a cloth in free fall
    # stays undeformed: nothing for the unstable step to amplify).
    small_scene["time"]["dt"] = 0.03
    small_scene["obstacles"] = []
    small_scene["panels"][0]["scale"] = [1.5, 1, 1]
    small_scene["pins"] = [{"panel": "cloth", "corner": "top_left"}]
    sim = raycloth.Simulator(small_scene, allow_unstable_dt=True)
    with pytest.raises(raycloth.SimulationError, match=r"the simulation blew up at step \d+ .*vertex \d+ of panel 'cloth'"):
        sim.step(1000)
    assert sim.steps == 6
    # run_scene: the folder keeps the frames so far and run.json names the error.
    with pytest.raises(raycloth.SimulationError) as e:
        raycloth.run_scene(small_scene, tmp_path / "out", allow_unstable_dt=True, duration=100.0)
    assert json.loads((tmp_path / "out" / "run.json").read_text())["error"] == str(e.value)


def test_an_unwritable_output_folder(small_scene, tmp_path):
    (tmp_path / "file").write_text("x")
    with pytest.raises(raycloth.InputError) as e:
        raycloth.run_scene(small_scene, tmp_path / "file")
    assert str(e.value) == f"{tmp_path / 'file'}: cannot write the output folder: Not a directory"


def test_a_file_that_cannot_be_written_during_a_run(cli, small_scene, tmp_path):
    # A directory where frame 3 goes: the run stops there, as the command line does, with its text.
    path = tmp_path / "small.json"
    path.write_text(json.dumps(small_scene))
    for name in ("cli", "py"):
        (tmp_path / name / "frames" / "cloth_0003.obj").mkdir(parents=True)
    r = subprocess.run([cli, "run", str(path), "--out", str(tmp_path / "cli"), "--quiet"], capture_output=True, text=True)
    assert r.returncode == 1
    with pytest.raises(raycloth.Error) as e:
        raycloth.run_scene(path, tmp_path / "py")
    assert type(e.value) is raycloth.Error
    out = tmp_path / "py" / "frames" / "cloth_0003.obj"
    assert str(e.value) == f"{out}: cannot rename from {out}.tmp: Is a directory"
    assert r.stderr.strip() == f"raycloth: error: {e.value}".replace("/py/", "/cli/")
    assert (tmp_path / "py" / "frames" / "cloth_0002.obj").is_file()
