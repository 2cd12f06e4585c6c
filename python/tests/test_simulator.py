"""The Simulator from Python: scenes from files, text and dicts; numpy views that alias the
simulator's memory; state edits, pins, obstacles moved by hand; the exact check."""
import gc
import json
import weakref

import numpy as np
import pytest

import raycloth

G = np.float32(-9.81)


def no_obstacles(scene):
    scene["obstacles"] = []
    return scene


def test_a_scene_from_a_file_text_or_dict_is_the_same_scene(small_scene, tmp_path):
    path = tmp_path / "small.json"
    path.write_text(json.dumps(small_scene))
    scenes = [raycloth.Scene.from_file(path), raycloth.load_scene(str(path)),
              raycloth.Scene.from_json(json.dumps(small_scene)), raycloth.Scene.from_dict(small_scene)]
    assert [s.name for s in scenes] == ["small_moving_sphere"] * 4
    assert scenes[0].source == str(path) and scenes[2].source == "<string>" and scenes[3].source == "<dict>"
    assert scenes[0].dt == 0.0004 and scenes[0].fps == 30 and scenes[0].obstacle_names == ["sphere"]
    sims = [raycloth.Simulator(s) for s in scenes]
    for sim in sims:
        sim.step(20)
    for sim in sims[1:]:
        np.testing.assert_array_equal(sim.positions, sims[0].positions)
    default = raycloth.Scene.default()
    assert default.name == "seed_drape" and default.panel_names == ["half_a", "half_b", "top"]


def test_positions_and_velocities_are_views_of_the_simulators_memory(small_scene):
    sim = raycloth.Simulator(small_scene, threads=1)
    x, v = sim.positions, sim.velocities
    assert x.dtype == np.float32 and x.shape == (225, 3) and v.dtype == np.float32 and v.shape == (225, 3)
    assert x.flags.c_contiguous and not x.flags.owndata and not x.flags.writeable
    # Two reads are one memory; a step changes the array already held.
    assert np.shares_memory(x, sim.positions) and np.shares_memory(v, sim.velocities)
    before = x.copy()
    sim.step(5)
    assert not np.array_equal(x, before)
    assert np.array_equal(x, sim.positions) and np.shares_memory(x, sim.positions)
    with pytest.raises(ValueError):
        x[0, 0] = 1.0  # read-only: write a state back with set_state
    # set_state writes into the same memory.
    sim.set_state(before, np.zeros((225, 3)))
    np.testing.assert_array_equal(x, before)
    assert not v.any()
    # The view keeps the simulator alive.
    ref = weakref.ref(sim)
    del sim
    gc.collect()
    assert ref() is not None
    np.testing.assert_array_equal(x, before)
    del x, v
    gc.collect()
    assert ref() is None


def test_set_state_then_one_step_falls_freely(small_scene):
    # A flat cloth at rest (springs at their rest lengths) lifted 2 m with no velocity: one explicit
    # Euler step gives v = g dt and x += v dt (damping acts on v = 0: nothing). Every vertex has the
    # same y, so the lift changes no spring length.
    sim = raycloth.Simulator(no_obstacles(small_scene))
    x0 = sim.positions.copy() + np.float32([0, 2.0, 0])
    sim.set_state(x0, np.zeros_like(x0))
    np.testing.assert_array_equal(sim.positions, x0)
    sim.step()
    dt = np.float32(0.0004)
    v = sim.velocities
    np.testing.assert_allclose(v[:, 1], G * dt, rtol=1e-4)
    np.testing.assert_allclose(v[:, [0, 2]], 0, atol=1e-6)
    np.testing.assert_allclose(sim.positions, x0 + v * dt, atol=1e-7)


def test_stats(small_scene):
    sim = raycloth.Simulator(small_scene)
    assert sim.stats["hits"] == 0 and sim.stats["bound_refreshes"] == 0
    sim.step_until(0.15)  # the cloth lies on the sphere
    s = sim.stats
    assert s["hits"] > 0 and s["bound_refreshes"] > 0 and s["unconverged_steps"] == 0
    assert set(s["stage_seconds"]) == {"integrate", "update", "cast", "respond", "contact", "bound"}
    assert sum(s["stage_seconds"].values()) > 0


def test_step_until(small_scene):
    sim = raycloth.Simulator(small_scene)
    sim.step_until(0.05)
    assert sim.steps == 125 and sim.time == pytest.approx(0.05)
    sim.step_until(0.01)  # behind: nothing
    sim.step(0)
    assert sim.steps == 125
    with pytest.raises(ValueError):
        sim.step(-1)
    with pytest.raises(ValueError):
        sim.step_until(float("nan"))


def test_pinned_vertices_stay_put(small_scene):
    sim = raycloth.Simulator(no_obstacles(small_scene))
    corners = [0, 14, 210, 224]
    sim.pin(np.array(corners[:2]))  # any sequence of indices
    sim.pin(corners[2:])
    assert sim.pinned.sum() == 4 and sim.pinned[corners].all()
    x0 = sim.positions.copy()
    sim.step(200)
    np.testing.assert_array_equal(sim.positions[corners], x0[corners])
    assert not sim.velocities[corners].any()
    assert sim.positions[112, 1] < x0[112, 1] - 0.01  # the middle sags
    # Moved by set_state, they stay where they are put.
    x = sim.positions.copy()
    x[corners, 1] += 0.05
    sim.set_state(x)
    sim.step(50)
    np.testing.assert_array_equal(sim.positions[corners], x[corners])


def test_an_obstacle_moved_by_hand_pushes_the_cloth(small_scene):
    # The sphere rises 1 mm per step (2.5 m/s) for 0.08 s while the cloth falls onto it: the cloth
    # rides on top, clean, 2 mm above it at the least.
    scene = small_scene
    scene["obstacles"][0].pop("motion")
    sim = raycloth.Simulator(scene)
    rest = sim.obstacle_vertices(0)
    for k in range(1, 201):
        m = np.eye(4)
        m[1, 3] = 0.001 * k
        sim.move_obstacle(0, transform=m)
        sim.step()
    now = sim.obstacle_vertices(0)
    np.testing.assert_allclose(now, rest + np.float32([0, 0.2, 0]), atol=1e-6)
    top = 0.4 + 0.2
    assert sim.positions[112, 1] > top  # the middle vertex, above the sphere's top
    assert sim.velocities[112, 1] > 1.0  # carried upwards
    assert sim.check()["clean"]
    # By vertices: the obstacle goes exactly there.
    target = now + np.float32([0.01, 0, 0])
    sim.move_obstacle(0, vertices=target)
    sim.step()
    np.testing.assert_array_equal(sim.obstacle_vertices(0), target)
    assert sim.obstacle_triangles(0).shape == (1152, 3)


def test_check_finds_a_vertex_put_inside_the_sphere(small_scene):
    sim = raycloth.Simulator(small_scene)
    c = sim.check()
    assert c["clean"] and c["crossings"] == 0 and c["vertices_inside"] == 0 and c["description"].startswith("0 crossings")
    x = sim.positions.copy()
    x[112] = [0, 0, 0]  # the middle vertex into the sphere's centre
    sim.set_state(x)
    c = sim.check()
    assert c["failed"] and c["vertices_inside"] == 1 and c["crossings"] == 0
    assert "vertex 112" in c["description"] or "112" in c["description"]


def test_step_releases_the_gil(small_scene):
    # Python code of another thread runs all through a step() call: no long gap between its
    # samples (were the GIL held while stepping, it would wait for the whole call).
    import threading
    import time
    sim = raycloth.Simulator(small_scene, threads=1)
    worker = threading.Thread(target=sim.step, args=(100,))
    samples = [time.perf_counter()]
    worker.start()
    while worker.is_alive():
        samples.append(time.perf_counter())
    worker.join()
    assert sim.steps == 100
    total = samples[-1] - samples[0]
    assert max(np.diff(samples)) < 0.5 * total, (max(np.diff(samples)), total)


def test_implicit_steps_are_cut_only_while_a_moving_body_is_within_reach(small_scene):
    # The sphere under the cloth slides at 0.5 m/s from t = 0.1 s, 8.3 mm a step of 1/60 s: before
    # it moves and while it is still far below the falling cloth, the steps are not cut; once it
    # moves under the cloth they are, into 9 substeps (1 mm each; one layer, so none is taken again).
    small_scene["time"] = {"dt": 1 / 60, "integrator": "implicit", "iterations": 20, "duration": 0.5, "fps": 30}
    small_scene["panels"][0]["position"] = [0, 0.6, 0]
    sim = raycloth.Simulator(small_scene, threads=1)
    sim.step(6)  # t = 0.1 s: nothing has moved yet
    assert sim.stats["solves"] == 6 and sim.stats["substeps"] == 1
    sim.step(18)  # t = 0.4 s: the cloth lies on the sliding sphere
    s = sim.stats
    assert s["substeps"] == 9 and s["steps_taken_again"] == 0 and s["entered_obstacles"] == 0
    assert 6 + 9 <= s["solves"] <= 6 + 18 * 9
    assert sim.check()["clean"]
