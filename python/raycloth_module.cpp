// The Python module `raycloth`: scenes from files, JSON text or dicts; a Simulator whose positions
// and velocities are numpy views of its own memory; the exact check; runs to an output folder as
// `raycloth run` writes them. docs/python.md describes it.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <tbb/task_arena.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "check/exact_check.h"
#include "io/checkpoint.h"
#include "io/run.h"
#include "raycloth/error.h"
#include "raycloth/scene.h"
#include "raycloth/simulator.h"
#include "sim/backend.h"
#include "sim/model.h"
#include "sim/model_check.h"

namespace py = pybind11;
using namespace raycloth;

namespace {

static_assert(sizeof(Vec3) == 3 * sizeof(float), "Vec3 must be three packed floats to be viewed as (n, 3)");

// The exception classes (created once, kept for the life of the process).
PyObject* g_error = nullptr;
PyObject* g_input_error = nullptr;
PyObject* g_simulation_error = nullptr;

// A path-like object (str, pathlib.Path) as a string.
std::string fspath(const py::handle& p) { return py::str(py::module_::import("os").attr("fspath")(p)); }

SceneDef scene_from_json(const std::string& text, const std::string& origin) { return parse_scene(text, origin); }

SceneDef scene_from_dict(const py::dict& d, const std::string& origin) {
  const std::string text = py::str(py::module_::import("json").attr("dumps")(d, py::arg("allow_nan") = true));
  return parse_scene(text, origin);
}

// What the functions taking a scene accept: a Scene, a dict, or a path to a scene file.
SceneDef to_scene(const py::handle& obj) {
  if (py::isinstance<SceneDef>(obj)) return obj.cast<SceneDef>();
  if (py::isinstance<py::dict>(obj)) return scene_from_dict(obj.cast<py::dict>(), "<dict>");
  const std::string path = fspath(obj);
  py::gil_scoped_release release;
  return load_scene_file(path);
}

// A read-only float32 (n, 3) array over `a`'s memory, keeping `owner` alive while it exists.
py::array view_of(std::vector<Vec3>& a, py::handle owner) {
  py::array_t<float> arr({py::ssize_t(a.size()), py::ssize_t(3)}, {py::ssize_t(sizeof(Vec3)), py::ssize_t(sizeof(float))},
                         reinterpret_cast<float*>(a.data()), owner);
  arr.attr("setflags")(py::arg("write") = false);
  return arr;
}

py::array copy_of(const std::vector<Vec3>& a, size_t first = 0, size_t count = SIZE_MAX) {
  count = std::min(count, a.size() - first);
  py::array_t<float> arr({py::ssize_t(count), py::ssize_t(3)});
  if (count) std::memcpy(arr.mutable_data(), a.data() + first, count * sizeof(Vec3));
  return arr;
}

py::array triangles_of(const std::vector<uint32_t>& idx, size_t first, size_t count, uint32_t base) {
  py::array_t<uint32_t> arr({py::ssize_t(count), py::ssize_t(3)});
  uint32_t* out = arr.mutable_data();
  for (size_t k = 0; k < 3 * count; ++k) out[k] = idx[3 * first + k] - base;
  return arr;
}

// An (n, 3) array of numbers as vectors (float64 and other types are converted).
std::vector<Vec3> to_vec3s(const py::handle& obj, const char* what) {
  auto a = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(obj);
  if (!a) throw py::type_error(std::string(what) + ": expected an array of shape (n, 3)");
  if (a.ndim() != 2 || a.shape(1) != 3)
  {
    std::string shape;
    for (py::ssize_t k = 0; k < a.ndim(); ++k) shape += (k ? ", " : "") + std::to_string(a.shape(k));
    throw py::value_error(std::string(what) + ": expected an array of shape (n, 3), got shape (" + shape + ")");
  }
  std::vector<Vec3> v(size_t(a.shape(0)));
  if (!v.empty()) std::memcpy(static_cast<void*>(v.data()), a.data(), v.size() * sizeof(Vec3));
  return v;
}

// Ctrl-C: runs Python's signal handlers (KeyboardInterrupt) with the GIL held.
void check_signals() {
  if (PyErr_CheckSignals() != 0) throw py::error_already_set();
}

py::dict check_dict(const CheckReport& c) {
  py::dict d;
  d["clean"] = c.clean();
  d["failed"] = c.failed();
  d["pinched_only"] = c.pinched_only();
  d["crossings"] = c.crossings;
  d["vertices_inside"] = c.vertices_inside;
  d["vertices_pinched"] = c.vertices_pinched;
  d["min_pinch_gap"] = std::isfinite(c.min_pinch_gap) ? py::object(py::float_(c.min_pinch_gap)) : py::object(py::none());
  d["pairs_tested"] = c.pairs_tested;
  d["vertices_tested"] = c.vertices_tested;
  d["description"] = describe(c);
  return d;
}

py::dict frame_dict(const FrameRecord& f) {
  py::dict d;
  d["index"] = f.index;
  d["time"] = f.time;
  d["step"] = f.step;
  d["hits"] = f.hits;
  d["kinetic_energy"] = f.kinetic_energy;
  if (f.crossings >= 0) {
    d["crossings"] = f.crossings;
    d["vertices_inside"] = f.vertices_inside;
    d["pinched"] = f.pinched;
  }
  return d;
}

// The Python Simulator: the simulator, and the task arena its steps run in (threads).
struct PySimulator {
  std::unique_ptr<tbb::task_arena> arena;
  std::unique_ptr<Simulator> sim;

  template <class F>
  void in_arena(F&& f) {
    arena->execute(std::forward<F>(f));
  }
  // n steps, one at a time with the GIL released; Ctrl-C is noticed between steps.
  void step(long n) {
    if (n < 0) throw py::value_error("step: n must not be negative (got " + std::to_string(n) + ")");
    for (long k = 0; k < n; ++k) {
      {
        py::gil_scoped_release release;
        in_arena([&] { sim->step(1); });
      }
      if (PyErr_CheckSignals() != 0) {
        sim->positions();
        throw py::error_already_set();
      }
    }
    sim->positions();  // the views show the state at time()
  }
};

std::unique_ptr<tbb::task_arena> make_arena(int threads) {
  if (threads < 0) throw py::value_error("threads: must be 0 (all cores) or positive (got " + std::to_string(threads) + ")");
  return std::make_unique<tbb::task_arena>(threads > 0 ? threads : int(tbb::task_arena::automatic));
}

const char* kModuleDoc = R"(raycloth: a mass-spring cloth simulator with ray-traced collision detection.

Load a scene (Scene.from_file / from_json / from_dict, or load_scene), step it with a Simulator
(positions and velocities are float32 (n, 3) numpy views of the simulator's memory), run the exact
penetration check on the current state, or run a whole scene to an output folder as `raycloth run`
does (run_scene, with a per-frame callback). Errors are raycloth.InputError (bad input: a ValueError,
with .file, .field and .reason) and raycloth.SimulationError (a blow-up, a device that cannot run:
a RuntimeError), both subclasses of raycloth.Error (raised itself for a file that cannot be written
during a run), with the same "FILE: FIELD: REASON" text as the command line. Ctrl-C stops a long step() or run_scene() with KeyboardInterrupt. See docs/python.md.)";

}  // namespace

PYBIND11_MODULE(raycloth, m) {
  m.doc() = kModuleDoc;
  m.attr("__version__") = RAYCLOTH_VERSION;

  // ---- Exceptions ----
  g_error = PyErr_NewExceptionWithDoc(
      "raycloth.Error",
      "Base class of raycloth's errors, and itself the error of a failure that is neither bad input nor the "
      "simulation's: a file that cannot be written during a run (naming it and why), the ray tracer's errors.",
      PyExc_Exception, nullptr);
  {
    py::tuple bases = py::make_tuple(py::handle(g_error), py::handle(PyExc_ValueError));
    g_input_error = PyErr_NewExceptionWithDoc(
        "raycloth.InputError",
        "Bad input: a scene, a mesh, an argument or an output folder. str() is 'FILE: FIELD: REASON' as the command "
        "line prints it; .file, .field and .reason hold the parts.",
        bases.ptr(), nullptr);
    py::tuple sim_bases = py::make_tuple(py::handle(g_error), py::handle(PyExc_RuntimeError));
    g_simulation_error = PyErr_NewExceptionWithDoc(
        "raycloth.SimulationError",
        "A simulation that cannot go on: a blow-up (naming the step, the panel and the vertex), a device that cannot "
        "run, an edit the device does not take.",
        sim_bases.ptr(), nullptr);
  }
  m.attr("Error") = py::handle(g_error);
  m.attr("InputError") = py::handle(g_input_error);
  m.attr("SimulationError") = py::handle(g_simulation_error);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const InputError& e) {
      py::object exc = py::reinterpret_borrow<py::object>(g_input_error)(e.what());
      exc.attr("file") = e.file();
      exc.attr("field") = e.field();
      exc.attr("reason") = e.reason();
      PyErr_SetObject(g_input_error, exc.ptr());
    } catch (const SimulationError& e) {
      PyErr_SetString(g_simulation_error, e.what());
    } catch (const py::builtin_exception&) {
      throw;  // pybind11's own (ValueError, TypeError, ...): translated by pybind11
    } catch (const std::runtime_error& e) {
      PyErr_SetString(g_error, e.what());  // a file that cannot be written, the ray tracer's errors
    }
  });

  // ---- Scene ----
  py::class_<SceneDef>(m, "Scene", R"(A scene: cloth panels, seams, pins, obstacles, time and output settings
(docs/scenes.md). Build one with Scene.from_file, Scene.from_json, Scene.from_dict or Scene.default().)")
      .def_static(
          "from_file", [](const py::object& path) { return to_scene(path); }, py::arg("path"),
          "Reads a scene file (JSON with comments); relative mesh paths are resolved against its folder.")
      .def_static(
          "from_json",
          [](const std::string& text, const std::string& origin) {
            py::gil_scoped_release release;
            return scene_from_json(text, origin);
          },
          py::arg("text"), py::arg("origin") = "<string>",
          "Parses scene text. `origin` names it in errors; relative mesh paths are resolved against its folder.")
      .def_static("from_dict", &scene_from_dict, py::arg("scene"), py::arg("origin") = "<dict>",
                  "A scene from a dict shaped like a scene file's JSON (docs/scenes.md).")
      .def_static("default", &default_scene, "The paper's experiment (scenes/seed_drape.json, compiled in).")
      .def_readonly("name", &SceneDef::name)
      .def_readonly("source", &SceneDef::source, "The file it came from ('' for the built-in scene).")
      .def_property_readonly("dt", [](const SceneDef& s) { return s.time.dt; }, "Seconds per step.")
      .def_property_readonly("fps", [](const SceneDef& s) { return s.time.fps; }, "Output frames per simulated second.")
      .def_property(
          "duration", [](const SceneDef& s) { return s.time.duration; },
          [](SceneDef& s, double d) {
            if (!(d > 0) || !std::isfinite(d))
              throw InputError(s.source, "/time/duration", "must be positive (got " + std::to_string(d) + ")");
            s.time.duration = d;
          },
          "Simulated seconds of a run (run_scene).")
      .def_property_readonly(
          "panel_names",
          [](const SceneDef& s) {
            std::vector<std::string> n;
            for (const auto& p : s.panels) n.push_back(p.name);
            return n;
          })
      .def_property_readonly("obstacle_names",
                             [](const SceneDef& s) {
                               std::vector<std::string> n;
                               for (const auto& o : s.obstacles) n.push_back(o.name);
                               return n;
                             })
      .def("__repr__", [](const SceneDef& s) {
        return "<raycloth.Scene '" + s.name + "' from " + (s.source.empty() ? std::string("<built-in>") : s.source) +
               ": " + std::to_string(s.panels.size()) + " panels, " + std::to_string(s.obstacles.size()) +
               " obstacles, dt " + py::str(py::float_(s.time.dt)).cast<std::string>() + " s>";
      });

  m.def("load_scene", &to_scene, py::arg("source"),
        "A scene from a path to a scene file, a dict shaped like one, or a Scene (returned as a copy).");

  // ---- Simulator ----
  py::class_<PySimulator>(m, "Simulator", R"(Steps a scene.

positions and velocities are read-only float32 arrays of shape (n, 3) that alias the simulator's
own memory (no copy): the same array shows the new state after every step(), and it keeps the
Simulator alive for as long as it exists (take .copy() to keep a state). Write a state back with
set_state(). Vertex i is the same vertex in positions, velocities, triangles and pin(), and in a
run's OBJ frames when no seam joins panels (seam partners are written once there).)")
      .def(py::init([](const py::object& scene, const std::string& device, int threads, bool allow_unstable_dt) {
             SceneDef s = to_scene(scene);
             auto p = std::make_unique<PySimulator>();
             p->arena = make_arena(threads);
             SimOptions o;
             o.device = device;
             o.allow_unstable_dt = allow_unstable_dt;
             py::gil_scoped_release release;
             p->in_arena([&] { p->sim = std::make_unique<Simulator>(s, o); });
             p->sim->positions();
             return p;
           }),
           py::arg("scene"), py::arg("device") = "cpu", py::arg("threads") = 0, py::arg("allow_unstable_dt") = false,
           R"(scene: a Scene, a dict or a path. device: "cpu", "cuda" or "auto". threads: worker threads
(0: all cores). Raises InputError for a scene that does not fit together (or a time step at or
above the stability limit, unless allow_unstable_dt) and SimulationError for a device that
cannot run.)")
      .def(
          "step", [](PySimulator& p, long n) { p.step(n); }, py::arg("n") = 1,
          "Advances n steps of dt with the GIL released. Raises SimulationError on a blow-up (naming the step, the "
          "panel and the vertex) and KeyboardInterrupt on Ctrl-C, after the last whole step.")
      .def(
          "step_until",
          [](PySimulator& p, double t) {
            if (!std::isfinite(t)) throw py::value_error("step_until: t must be finite");
            const double dt = p.sim->scene().time.dt;
            const long long target = std::llround(t / dt);
            if (target > (long long)p.sim->steps()) p.step(long(target - (long long)p.sim->steps()));
          },
          py::arg("t"), "Steps up to the step nearest simulated time t (nothing when t is not ahead).")
      .def_property_readonly("time", [](PySimulator& p) { return p.sim->time(); }, "Simulated seconds so far.")
      .def_property_readonly("steps", [](PySimulator& p) { return p.sim->steps(); }, "Steps so far.")
      .def_property_readonly("dt", [](PySimulator& p) { return p.sim->scene().time.dt; })
      .def_property_readonly("device", [](PySimulator& p) { return p.sim->device(); })
      .def_property_readonly("scene", [](PySimulator& p) { return p.sim->scene(); }, "A copy of the scene.")
      .def_property_readonly("num_vertices", [](PySimulator& p) { return p.sim->model().num_vertices(); })
      .def_property_readonly(
          "positions",
          [](py::object self) {
            PySimulator& p = self.cast<PySimulator&>();
            p.sim->positions();
            return view_of(const_cast<std::vector<Vec3>&>(p.sim->positions()), self);
          },
          "Cloth vertex positions at `time` (metres): a read-only float32 (n, 3) view of the simulator's memory.")
      .def_property_readonly(
          "velocities",
          [](py::object self) {
            PySimulator& p = self.cast<PySimulator&>();
            return view_of(const_cast<std::vector<Vec3>&>(p.sim->velocities()), self);
          },
          "Cloth vertex velocities at `time` (m/s): a read-only float32 (n, 3) view of the simulator's memory.")
      .def_property_readonly(
          "triangles",
          [](PySimulator& p) {
            const auto& t = p.sim->model().triangles;
            return triangles_of(t, 0, t.size() / 3, 0);
          },
          "The cloth's triangles (uint32, (m, 3)), panel by panel, indexing positions.")
      .def_property_readonly(
          "pinned",
          [](PySimulator& p) {
            const ClothModel& m = p.sim->model();
            py::array_t<bool> a(py::ssize_t(m.num_vertices()));
            for (uint32_t i = 0; i < m.num_vertices(); ++i) a.mutable_at(i) = m.inv_mass[m.alias[i]] == 0.0f;
            return a;
          },
          "Per vertex, whether it is pinned (a copy).")
      .def(
          "set_state",
          [](PySimulator& p, const py::object& positions, const py::object& velocities) {
            std::vector<Vec3> x = to_vec3s(positions, "positions");
            std::vector<Vec3> v = velocities.is_none() ? p.sim->velocities() : to_vec3s(velocities, "velocities");
            p.sim->set_state(x, v);
          },
          py::arg("positions"), py::arg("velocities") = py::none(),
          R"(Replaces the state at `time`: positions and velocities (n, 3), any numeric type (copied; None
keeps the velocities). Seam partners take their representative's values; the displacement bound
starts over from the new positions (cloth the new state puts through cloth stays through: check()
tells). InputError for a wrong size or a value that is not finite.)")
      .def(
          "pin", [](PySimulator& p, const std::vector<uint32_t>& v) { p.sim->pin(v); }, py::arg("indices"),
          "Pins cloth vertices where they are: they stop and stay put until set_state() moves them.")
      .def_property_readonly("obstacle_names", [](PySimulator& p) { return p.sim->obstacles().names; })
      .def(
          "obstacle_vertices",
          [](PySimulator& p, std::optional<size_t> i) {
            const ObstacleSet& o = p.sim->obstacles();
            const std::vector<Vec3> x = p.sim->obstacle_vertices();
            if (!i) return copy_of(x);
            if (*i >= o.names.size()) throw py::index_error("obstacle " + std::to_string(*i) + " does not exist");
            const size_t first = o.first_vertex[*i];
            const size_t end = *i + 1 < o.first_vertex.size() ? o.first_vertex[*i + 1] : x.size();
            return copy_of(x, first, end - first);
          },
          py::arg("obstacle") = py::none(),
          "World-space vertices of one obstacle (by index), or of all of them in order, at `time` (a copy).")
      .def(
          "obstacle_triangles",
          [](PySimulator& p, size_t i) {
            const ObstacleSet& o = p.sim->obstacles();
            if (i >= o.names.size()) throw py::index_error("obstacle " + std::to_string(i) + " does not exist");
            const size_t first = o.first_triangle[i];
            const size_t end = i + 1 < o.first_triangle.size() ? o.first_triangle[i + 1] : o.world.num_triangles();
            return triangles_of(o.world.indices, first, end - first, o.first_vertex[i]);
          },
          py::arg("obstacle"), "Triangles of one obstacle (uint32, (m, 3)), indexing obstacle_vertices(obstacle).")
      .def(
          "move_obstacle",
          [](PySimulator& p, size_t i, const py::object& vertices, const py::object& transform) {
            const ObstacleSet& o = p.sim->obstacles();
            if (vertices.is_none() == transform.is_none())
              throw py::value_error("move_obstacle: give either vertices or transform");
            if (!vertices.is_none()) {
              p.sim->move_obstacle(i, to_vec3s(vertices, "vertices"));
              return;
            }
            if (i >= o.names.size()) throw py::index_error("obstacle " + std::to_string(i) + " does not exist");
            auto m = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(transform);
            if (!m || m.ndim() != 2 || m.shape(0) < 3 || m.shape(0) > 4 || m.shape(1) != 4)
              throw py::value_error("transform: expected a 4 x 4 (or 3 x 4) matrix");
            auto M = m.unchecked<2>();
            std::vector<Vec3> world;
            for (const Vec3& v : o.local[i].vertices) {
              double r[3];
              for (int k = 0; k < 3; ++k) r[k] = M(k, 0) * v.x + M(k, 1) * v.y + M(k, 2) * v.z + M(k, 3);
              world.push_back(make_vec3(float(r[0]), float(r[1]), float(r[2])));
            }
            p.sim->move_obstacle(i, world);
          },
          py::arg("obstacle"), py::arg("vertices") = py::none(), py::arg("transform") = py::none(),
          R"(Moves an obstacle by hand: over the next step it goes in a straight line to `vertices`
(world space, (m, 3), as obstacle_vertices(obstacle)) or to its own mesh under `transform` (a 4 x 4
matrix replacing the scene's transform and motion), and stays there until moved again. Call it
before each step for a motion of your own. The CPU device only (SimulationError elsewhere).)")
      .def(
          "check",
          [](PySimulator& p) {
            const Simulator& s = *p.sim;
            const std::vector<Vec3>& x = p.sim->positions();
            const std::vector<Vec3> ox = s.obstacle_vertices();
            CheckReport r;
            {
              py::gil_scoped_release release;
              p.in_arena([&] {
                r = check_state(cloth_check_mesh(s.model(), x), obstacle_check_mesh(s.obstacles(), ox),
                                check_thickness(s.scene()));
              });
            }
            return check_dict(r);
          },
          R"(The exact penetration check of the current state, as run.json reports it per frame: every
cloth edge against every cloth triangle sharing no vertex with it (CGAL's exact predicates) and
every cloth vertex against every obstacle. A dict: clean, failed, pinched_only, crossings,
vertices_inside, vertices_pinched, min_pinch_gap, pairs_tested, vertices_tested, description.)")
      .def_property_readonly(
          "stats",
          [](PySimulator& p) {
            const Simulator& s = *p.sim;
            py::dict d;
            d["hits"] = s.last_hits();
            for_each_total(s.totals(), [&](const char* name, const char*, uint64_t value) { d[name] = value; });
            d["max_residual"] = s.totals().max_residual;
            d["max_obstacle_move"] = s.totals().max_obstacle_move;
            d["solves"] = s.solves();
            d["substeps"] = s.substeps();
            const StageTimes& t = s.stage_times();
            d["stage_seconds"] = py::dict(py::arg("integrate") = t.integrate, py::arg("update") = t.update,
                                          py::arg("cast") = t.cast, py::arg("respond") = t.respond,
                                          py::arg("contact") = t.contact, py::arg("bound") = t.bound);
            return d;
          },
          R"(The step's counters so far, as run.json's "contact" names them: hits (cloth vertices with an
entry in the collision buffer in the last step), pushed_by_obstacles, clamped_by_bound,
obstacle_conflicts, push_shortened_by_bound, bound_refreshes, bound_partial_refreshes,
cloth_contact_pairs, moved_by_contact_solve, contact_solve_rounds, bound_passes,
pushed_out_of_overlaps, swept_bound_rounds, swept_bound_stops, entered_obstacles (sums over all steps), unconverged_steps,
steps_taken_again and max_residual (the implicit integrator), solves (the steps the
backend took: one a step, or one a substep) and substeps (the most substeps a step was cut into), max_obstacle_move (the largest
move of an obstacle vertex in one step, metres), and stage_seconds (wall-clock seconds per stage).)")
      .def("__repr__", [](PySimulator& p) {
        return "<raycloth.Simulator '" + p.sim->scene().name + "' on " + p.sim->device() + ": " +
               std::to_string(p.sim->model().num_vertices()) + " vertices, step " + std::to_string(p.sim->steps()) + ">";
      });

  m.def(
      "cuda_available",
      [] {
        std::string why;
        const bool ok = cuda_usable(&why);
        return py::make_tuple(ok, why);
      },
      "(True, '') when the CUDA backend is built and a GPU is usable; otherwise (False, what is missing).");

  // ---- Runs ----
  m.def(
      "run_scene",
      [](const py::object& scene, const py::object& out, const std::optional<std::vector<std::string>>& formats,
         std::optional<double> duration, const std::string& device, int threads, bool check, bool allow_unstable_dt,
         int checkpoint_every, bool quiet, const py::object& on_frame) {
        SceneDef s = to_scene(scene);
        RunOptions opt;
        opt.out_dir = fspath(out);
        opt.sim.device = device;
        opt.sim.allow_unstable_dt = allow_unstable_dt;
        opt.duration = duration;
        opt.check = check;
        opt.checkpoint_every = checkpoint_every;
        opt.quiet = quiet;
        if (s.source.empty()) opt.scene_text = std::string(default_scene_text());
        if (formats) opt.formats = *formats;
        if (!on_frame.is_none()) {
          opt.on_frame = [&on_frame](Simulator& sim, const FrameRecord& r) {
            py::gil_scoped_acquire acquire;
            check_signals();
            py::dict d = frame_dict(r);
            d["positions"] = copy_of(sim.positions());
            d["velocities"] = copy_of(sim.velocities());
            on_frame(py::module_::import("types").attr("SimpleNamespace")(**d));
          };
        }
        opt.between_steps = [] {
          py::gil_scoped_acquire acquire;
          check_signals();
        };
        auto arena = make_arena(threads);
        RunReport r;
        {
          py::gil_scoped_release release;
          arena->execute([&] { r = run_scene(s, opt); });
        }
        py::dict d;
        d["scene"] = r.scene;
        d["device"] = r.device;
        d["steps"] = r.steps;
        d["simulated_time"] = r.simulated_time;
        d["wall_time"] = r.wall_time;
        d["steps_per_second"] = r.steps_per_second;
        py::list frames;
        for (const FrameRecord& f : r.frames) frames.append(frame_dict(f));
        d["frames"] = frames;
        py::dict c;
        c["enabled"] = r.check.enabled;
        c["frames_checked"] = r.check.frames_checked;
        c["bad_frames"] = r.check.bad_frames;
        c["first_bad_frame"] = r.check.first_bad_frame;
        c["first_problem"] = r.check.first_problem;
        c["pinched_frames"] = r.check.pinched_frames;
        c["first_pinch"] = r.check.first_pinch;
        d["check"] = c;
        d["outputs"] = r.outputs;
        return d;
      },
      py::arg("scene"), py::arg("out"), py::kw_only(), py::arg("formats") = py::none(), py::arg("duration") = py::none(),
      py::arg("device") = "cpu", py::arg("threads") = 0, py::arg("check") = true, py::arg("allow_unstable_dt") = false,
      py::arg("checkpoint_every") = 5, py::arg("quiet") = true, py::arg("on_frame") = py::none(),
      R"(Runs a scene (a Scene, a dict or a path) to the folder `out` and writes what `raycloth run`
writes there (the same bytes, timing.json and summary.png aside): frames in `formats` (default the
scene's output.formats), obstacles.obj, run.json, timing.json, summary.png. on_frame(frame) is
called after each output frame is written (frame 0 included) with an object holding index, time,
step, hits, kinetic_energy, crossings, vertices_inside, pinched (the exact check; absent when
check=False), and copies of positions and velocities. Returns a dict: scene, device, steps,
simulated_time, wall_time, steps_per_second, frames, check, outputs.

A callback that raises, or Ctrl-C, stops the run cleanly: the outputs end with the frames written
so far (cloth.pc2 and cloth.glb hold them), run.json and summary.png name the error, no checkpoint
stays, and the exception comes through. A blow-up does the same and raises SimulationError. A
frame that fails the exact check does not raise: see the result's check (bad_frames).)");
}
