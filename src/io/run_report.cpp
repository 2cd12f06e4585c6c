#include "io/run_report.h"

#include <spdlog/spdlog.h>

#include <cmath>

#include "sim/model.h"
#include "sim/seams.h"

namespace raycloth {

namespace {

// Seams sewn from apart: the stitches, the tolerance, the widest stitch when the seams should have
// closed (the first frame at or after sewing.close_time) and at the end, and the seams still open.
nlohmann::json seams_json(const RunReport& r, Simulator& sim) {
  const SceneDef& s = sim.scene();
  const float tol = seam_close_tolerance(s);
  nlohmann::json j = {{"stitches", sim.model().stitch_seam.size()},
                      {"welded", sim.stitches_welded()},
                      {"welds_put_off", sim.welds_put_off()},
                      {"close_time", s.sewing.close_time},
                      {"close_tolerance", tol}};
  const FrameRecord* at_close = nullptr;
  for (const FrameRecord& f : r.frames)
    if (!at_close && f.time >= s.sewing.close_time - 1e-9) at_close = &f;
  j["largest_gap_at_close_time"] = at_close ? nlohmann::json(at_close->seam_gap) : nlohmann::json(nullptr);
  j["largest_gap_at_end"] = r.frames.empty() ? 0.0 : r.frames.back().seam_gap;
  nlohmann::json open = nlohmann::json::array();
  for (const SeamGap& g : seam_gaps(sim.model(), sim.positions(), tol))
    if (g.largest > tol) {
      const SeamDef& sd = s.seams[g.seam];
      // Where the widest stitch is (its middle), and how many of the seam's stitches are open.
      const Vec3 mid = (g.a + g.b) * 0.5f;
      open.push_back({{"seam", g.seam}, {"a", sd.a.panel}, {"b", sd.b.panel}, {"largest_gap", g.largest},
                      {"largest_gap_at", {mid.x, mid.y, mid.z}}, {"open_stitches", g.open}, {"stitches", g.stitches}});
    }
  j["open_at_end"] = open;
  return j;
}

}  // namespace

nlohmann::json camera_json(const CameraDef& cam) {
  nlohmann::json camera = {{"fov", cam.fov}, {"resolution", {cam.width, cam.height}}, {"samples", cam.samples}};
  if (cam.position) camera["position"] = *cam.position;
  if (cam.target) camera["target"] = *cam.target;
  return camera;
}

nlohmann::json run_json(const RunReport& r, Simulator& sim) {
  const ClothModel& m = sim.model();
  nlohmann::json j;
  j["scene"] = r.scene;
  j["device"] = r.device;
  j["vertices"] = m.num_vertices();
  j["triangles"] = m.num_triangles();
  j["springs"] = {{"stretch", m.spring_counts[0]}, {"shear", m.spring_counts[1]}, {"bend", m.spring_counts[2]},
                  {"seam", m.spring_counts[3]}, {"total", m.springs.size()}};
  j["obstacle_triangles"] = sim.obstacles().world.num_triangles();
  // Openings of the obstacles that the step closed (collide/holes.h): loops found, capped, triangles.
  j["obstacle_holes"] = {{"found", sim.obstacles().holes_found}, {"capped", sim.obstacles().holes_capped},
                         {"cap_triangles", sim.obstacles().cap_triangles}};
  j["dt"] = sim.scene().time.dt;
  if (sim.dt_from_mesh()) j["dt_from_mesh"] = true;
  j["fps"] = sim.scene().time.fps;
  // The cloth thickness (metres): `raycloth check DIR` reads it to tell pinches from failures.
  j["thickness"] = check_thickness(sim.scene());
  // The scene's camera, so that `raycloth render DIR` shows the run as the run would have.
  j["camera"] = camera_json(sim.scene().output.camera);
  j["natural_period_T0"] = m.natural_period();
  j["steps"] = r.steps;
  j["simulated_time"] = r.simulated_time;
  nlohmann::json frames = nlohmann::json::array();
  for (const auto& f : r.frames) {
    nlohmann::json jf = {{"index", f.index}, {"time", f.time}, {"step", f.step}, {"hits", f.hits}, {"clamped", f.clamped},
                         {"pushed", f.pushed}, {"kinetic_energy", f.kinetic_energy}};
    if (f.crossings >= 0) {
      jf["crossings"] = f.crossings;
      jf["vertices_inside"] = f.vertices_inside;
      jf["pinched"] = f.pinched;
      jf["pinch_gap"] = std::isfinite(f.pinch_gap) ? nlohmann::json(f.pinch_gap) : nlohmann::json(nullptr);
    }
    if (!m.stitches.empty()) jf["seam_gap"] = f.seam_gap;
    frames.push_back(jf);
  }
  j["frames"] = frames;
  if (!m.stitches.empty()) j["seams"] = seams_json(r, sim);
  // Garments placed on a body: each panel's move out of it, whether it was wrapped around the legs
  // and its stretch there.
  if (!sim.panel_moves().empty()) {
    nlohmann::json placement = nlohmann::json::array();
    for (const Simulator::PanelMove& p : sim.panel_moves())
      placement.push_back({{"panel", p.panel}, {"moved", p.moved}, {"wrapped", p.wrapped}, {"stretched", p.stretched}});
    j["placement"] = placement;
  }
  // The run's totals (raycloth/totals.h), each in its section; the integrator's follow.
  j["contact"] = nlohmann::json::object();
  for_each_total(sim.totals(), [&](const char* name, const char* section, uint64_t value) {
    if (std::string(section) == "contact") j["contact"][name] = value;
  });
  // How fast the bodies moved: the largest move of an obstacle vertex in one step (metres).
  j["contact"]["max_obstacle_move"] = sim.totals().max_obstacle_move;
  // The integrator, and for the implicit one its convergence: the sweeps per step, the tolerance on
  // the last sweep's largest step, the steps (substeps) that did not reach it and the largest such step.
  const TimeDef& td = sim.scene().time;
  if (td.integrator == Integrator::Implicit)
    j["integrator"] = {{"name", "implicit"},           {"method", "implicit Euler, vertex block descent"},
                       {"iterations", td.iterations},  {"tolerance", td.tolerance},
                       {"unconverged_steps", sim.totals().unconverged}, {"max_residual", sim.totals().max_residual},
                       // Where a body moves, each step is cut into substeps, as many as the body
                       // near the cloth asks for in that step (Simulator::substeps): the most in one
                       // step, and the solves (substeps) of the run.
                       {"substeps", sim.substeps()}, {"solves", sim.solves()},
                       // Tries of a step undone and taken again in more substeps: they had left
                       // cloth inside a body (Simulator::advance).
                       {"steps_taken_again", sim.totals().retried}};
  else
    j["integrator"] = {{"name", "explicit"}, {"method", "explicit Euler, eq. (3)"}};
  if (r.check.enabled) {
    j["check"] = {{"method", "exact: every cloth edge against every cloth triangle sharing no vertex (CGAL filtered "
                             "exact orientation predicates); every cloth vertex against every obstacle (closed: "
                             "CGAL Side_of_triangle_mesh; open: winding number >= 1/2); on every written frame. "
                             "A vertex inside is pinched, not a failure, where the body's own gap at its way out "
                             "is below twice the thickness"},
                  {"frames_checked", r.check.frames_checked},
                  {"bad_frames", r.check.bad_frames},
                  {"first_bad_frame", r.check.first_bad_frame},
                  {"max_crossings", r.check.max_crossings},
                  {"max_vertices_inside", r.check.max_vertices_inside},
                  {"pinched_frames", r.check.pinched_frames},
                  {"first_pinched_frame", r.check.first_pinched_frame},
                  {"max_vertices_pinched", r.check.max_vertices_pinched},
                  {"min_pinch_gap", std::isfinite(r.check.min_pinch_gap) ? nlohmann::json(r.check.min_pinch_gap)
                                                                          : nlohmann::json(nullptr)},
                  {"closed_obstacles", r.check.closed_obstacles},
                  {"open_obstacles", r.check.open_obstacles}};
    if (!r.check.first_problem.empty()) j["check"]["first_problem"] = r.check.first_problem;
    if (!r.check.first_pinch.empty()) j["check"]["first_pinch"] = r.check.first_pinch;
  } else {
    j["check"] = {{"method", "none (run with the check turned off)"}};
  }
  j["outputs"] = r.outputs;
  if (!r.error.empty()) j["error"] = r.error;
  return j;
}

nlohmann::json timing_json(const RunReport& r) {
  nlohmann::json j;
  j["wall_time"] = r.wall_time;
  j["steps_per_second"] = r.steps_per_second;
  // A cheaper step that needs a smaller dt is no gain: simulated time per wall-clock time says so.
  j["simulated_seconds_per_wall_second"] = r.wall_time > 0 ? r.simulated_time / r.wall_time : 0.0;
  const double per = r.steps > 0 ? 1000.0 / double(r.steps) : 0.0;
  j["stage_ms_per_step"] = {{"forces_and_integration", r.stages.integrate * per},
                            {"acceleration_structure_update", r.stages.update * per},
                            {"ray_casting", r.stages.cast * per},
                            {"response", r.stages.respond * per},
                            {"contact_solve", r.stages.contact * per},
                            {"displacement_bound", r.stages.bound * per}};
  nlohmann::json frames = nlohmann::json::array();
  for (const auto& f : r.frames) frames.push_back({{"index", f.index}, {"steps_per_second", f.steps_per_second}});
  j["frames"] = frames;
  return j;
}

void warn_unconverged(const SceneDef& scene, Simulator& sim) {
  if (scene.time.integrator != Integrator::Implicit || sim.totals().unconverged == 0) return;
  // Each substep is a solve of its own (run.json's integrator.unconverged_steps counts solves).
  const std::string of = sim.solves() > sim.steps()
                             ? fmt::format("{} solves ({} steps, cut into up to {} substeps)", sim.solves(), sim.steps(),
                                           sim.substeps())
                             : fmt::format("{} steps", sim.steps());
  spdlog::warn("the implicit integrator did not converge in {} of {}: its last sweep still moved a vertex up to "
               "{:.3g} m (time.tolerance {:g} m); raise time.iterations or lower time.dt",
               sim.totals().unconverged, of, sim.totals().max_residual, scene.time.tolerance);
}

void warn_open_seams(Simulator& sim, const RunReport& r) {
  const ClothModel& m = sim.model();
  if (m.stitches.empty() || r.frames.empty()) return;
  const SceneDef& s = sim.scene();
  const float tol = seam_close_tolerance(s);
  for (const FrameRecord& f : r.frames)
    if (f.time >= s.sewing.close_time - 1e-9) {
      if (f.seam_gap > tol)
        spdlog::warn("seams still open at the end of the close time ({:g} s): the widest stitch is {:.3g} m apart "
                     "(sewing.close_tolerance {:g} m); run.json's seams lists those open at the end",
                     s.sewing.close_time, f.seam_gap, tol);
      break;
    }
  if (r.frames.back().time >= s.sewing.close_time - 1e-9 && r.frames.back().seam_gap > tol)
    spdlog::warn("seams open at the end of the run: the widest stitch is {:.3g} m apart", r.frames.back().seam_gap);
}

}  // namespace raycloth
