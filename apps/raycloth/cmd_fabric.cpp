// `raycloth fabric-test cantilever|drape|tensile --fabric NAME`: the standard fabric tests simulated
// on a preset (or on measurements given with --kes), with what the standards report
// (docs/materials.md). Exit codes: 0 done, 1 the simulation failed, 2 bad input.
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>

#include "commands.h"
#include "common.h"
#include "fabric/kes.h"
#include "fabric/measured.h"
#include "lab/fabric_tests.h"
#include "io/atomic_file.h"
#include "raycloth/error.h"

namespace raycloth::cli {

namespace {

struct FabricArgs {
  std::string test, fabric, integrator = "explicit", out, scene;
  std::vector<double> kes;
  double settle = 0, dt = 0;
  int iterations = 30, segments = 0, sectors = 96;
  uint32_t seed = 12345u;
  int repeats = 1;
  double ring_spacing = 0.006;
  std::vector<double> angles{0, 45, 90};
  double warp = 0;
  bool triangles = false;
  double edge = 0;
  bool quiet = false;
};

void write_text(const std::filesystem::path& path, const std::string& text) {
  write_file_atomically(path, [&](std::ostream& o) { o << text; });
}

}  // namespace

Action add_fabric_command(CLI::App& app) {
  auto a = std::make_shared<FabricArgs>();
  CLI::App* cmd = app.add_subcommand(
      "fabric-test", "Simulate a standard fabric test on a fabric preset: cantilever (ASTM D1388), drape (Cusick, ISO 9073-9) or tensile");
  cmd->add_option("test", a->test, "cantilever, drape or tensile")->required()->check(CLI::IsMember({"cantilever", "drape", "tensile"}));
  cmd->add_option("--fabric", a->fabric, "Fabric preset (docs/materials.md)")->required();
  cmd->add_option("--kes", a->kes, "Measurements replacing the preset's: W,B,G,EMT in KES-F units")->delimiter(',')->expected(4);
  cmd->add_option("--integrator", a->integrator, "explicit or implicit")->check(CLI::IsMember({"explicit", "implicit"}));
  cmd->add_option("--dt", a->dt, "Time step, seconds (default: half the explicit limit, 2 ms implicit)");
  cmd->add_option("--iterations", a->iterations, "Implicit sweeps per step");
  cmd->add_option("--settle", a->settle, "Simulated seconds to rest (default 1 cantilever and tensile, 2 drape)");
  cmd->add_option("--segments", a->segments, "Cantilever: grid cells along the overhang (default 16, fewer where the fabric needs)");
  cmd->add_option("--warp", a->warp, "Cantilever, measured fabrics: degrees from the strip's length to the warp (0: cut along the warp, 90: along the weft)");
  cmd->add_option("--angles", a->angles, "Tensile, measured fabrics: degrees from the warp to the pull (default 0,45,90)")->delimiter(',');
  cmd->add_flag("--triangles", a->triangles, "Tensile, measured fabrics: a specimen of triangles (a sewing pattern) instead of a grid");
  cmd->add_option("--edge", a->edge, "Tensile, measured fabrics: the grid's cell or the triangles' edge, metres (default 5 mm)");
  cmd->add_option("--sectors", a->sectors, "Drape: vertices around each ring of the specimen");
  cmd->add_option("--seed", a->seed, "Drape: seed of the specimen's small vertical noise");
  cmd->add_option("--repeats", a->repeats, "Drape: specimens to test, with seeds seed, seed + 1, ...; the mean is reported (ISO 9073-9 tests three)")->check(CLI::Range(1, 100));
  cmd->add_option("--ring-spacing", a->ring_spacing, "Drape: metres between the specimen's rings outside the disk");
  cmd->add_option("--scene", a->scene, "Drape: also write the test as a scene folder (scene.json, specimen.obj, disk.obj) for raycloth run");
  cmd->add_option("--out", a->out, "Folder for result.json (and drape.obj, tensile.csv)");
  cmd->add_flag("-q,--quiet", a->quiet, "Only the result line");
  return [cmd, a] {
    if (!cmd->parsed()) return 0;
    return guarded([&] {
      MaterialDef m = lab::preset_material(a->fabric);
      if (!a->kes.empty() && !m.fabric)
        throw InputError("command line", "--kes", "the measured fabric '" + a->fabric + "' takes no KES-F measurements");
      if (!a->kes.empty()) {
        m.fabric->W = a->kes[0], m.fabric->B = a->kes[1], m.fabric->G = a->kes[2], m.fabric->EMT = a->kes[3];
        m.density = float(fabric::weight_to_density(m.fabric->W));
        const std::pair<const char*, double> kes[] = {{"W", a->kes[0]}, {"B", a->kes[1]}, {"G", a->kes[2]}, {"EMT", a->kes[3]}};
        for (const auto& [key, value] : kes)
          if (!(value > 0) || !std::isfinite(value))
            throw InputError("command line", std::string("--kes: ") + key, fmt::format("must be a positive measurement (got {:g})", value));
      }
      lab::Stepping st;
      st.integrator = a->integrator == "implicit" ? Integrator::Implicit : Integrator::Explicit;
      st.dt = a->dt;
      st.iterations = a->iterations;
      st.settle = a->settle > 0 ? a->settle : (a->test == "drape" ? 2.0 : 1.0);
      const std::filesystem::path out = a->out;
      if (!out.empty()) std::filesystem::create_directories(out);
      nlohmann::json j;
      j["test"] = a->test;
      j["fabric"] = a->fabric;
      if (m.fabric) j["kes"] = {{"W", m.fabric->W}, {"B", m.fabric->B}, {"G", m.fabric->G}, {"EMT", m.fabric->EMT}};
      if (const fabric::MeasuredFabric* f = fabric::find_measured(m.measured)) j["source"] = f->source;
      j["integrator"] = a->integrator;
      const auto t0 = std::chrono::steady_clock::now();
      if (a->test == "cantilever") {
        lab::CantileverOptions o;
        o.stepping = st;
        o.segments = a->segments;
        o.warp = a->warp;
        j["warp_deg"] = a->warp;
        const lab::CantileverResult r = lab::cantilever_test(m, o);
        if (!a->quiet)
          for (const auto& t : r.tries) std::cout << fmt::format("overhang {:.2f} cm: chord {:.2f} degrees below level\n", 100 * t.overhang, t.angle);
        // Under 4 cells there is no coarser grid of 2 or more to extrapolate from: the figure is the grid's own.
        const std::string how = r.bending_length_coarse > 0
                                    ? fmt::format("{:.3f} cm with {} cells, {:.3f} cm with {}, extrapolated", 100 * r.bending_length_fine,
                                                  r.segments, 100 * r.bending_length_coarse, r.segments / 2)
                                    : fmt::format("{} cells, not extrapolated", r.segments);
        std::cout << fmt::format(
            "{}: bending length c = {:.3f} cm ({}), flexural rigidity G = W c^3 = {:.1f} mg cm; (B/W)^(1/3) = {:.3f} cm ({:+.1f} %)\n",
            a->fabric, 100 * r.bending_length, how, r.flexural_rigidity, 100 * r.predicted, 100 * (r.bending_length / r.predicted - 1));
        j["bending_length_fine_cm"] = 100 * r.bending_length_fine;
        j["segments"] = r.segments;
        j["bending_length_coarse_cm"] = 100 * r.bending_length_coarse;
        j["bending_length_cm"] = 100 * r.bending_length;
        j["overhang_cm"] = 100 * r.overhang;
        j["flexural_rigidity_mg_cm"] = r.flexural_rigidity;
        j["predicted_bending_length_cm"] = 100 * r.predicted;
        j["steps"] = r.steps;
        for (const auto& t : r.tries) j["tries"].push_back({{"overhang_cm", 100 * t.overhang}, {"angle_deg", t.angle}});
      } else if (a->test == "drape") {
        lab::DrapeOptions o;
        o.stepping = st;
        o.sectors = a->sectors;
        o.ring_spacing = a->ring_spacing;
        o.seed = a->seed;
        if (!a->scene.empty()) lab::write_drape_scene(m, o, a->scene);
        lab::DrapeResult r;
        double dc_sum = 0, dc_min = INFINITY, dc_max = -INFINITY, folds_sum = 0;
        for (int k = 0; k < a->repeats; ++k) {
          o.seed = a->seed + uint32_t(k);
          r = lab::drape_test(m, o);
          dc_sum += r.drape_coefficient, folds_sum += r.folds;
          dc_min = std::min(dc_min, r.drape_coefficient), dc_max = std::max(dc_max, r.drape_coefficient);
          if (a->repeats > 1 && !a->quiet)
            std::cout << fmt::format("seed {}: drape coefficient {:.1f} %, {} folds\n", o.seed, 100 * r.drape_coefficient, r.folds);
          j["specimens"].push_back({{"seed", o.seed}, {"drape_coefficient", r.drape_coefficient}, {"folds", r.folds}});
        }
        if (a->repeats > 1)
          std::cout << fmt::format("{}: drape coefficient {:.1f} % (mean of {}; {:.1f} to {:.1f} %), {:.1f} folds on average\n", a->fabric,
                                   100 * dc_sum / a->repeats, a->repeats, 100 * dc_min, 100 * dc_max, folds_sum / a->repeats);
        else
          std::cout << fmt::format("{}: drape coefficient {:.1f} %, {} folds (shadow {:.1f} cm^2; rim {:.1f} to {:.1f} cm from the axis)\n",
                                   a->fabric, 100 * r.drape_coefficient, r.folds, 1e4 * r.shadow_area, 100 * r.min_radius,
                                   100 * r.max_radius);
        j["drape_coefficient"] = dc_sum / a->repeats;
        j["folds"] = folds_sum / a->repeats;
        j["shadow_area_cm2"] = 1e4 * r.shadow_area;
        j["rim_radius_cm"] = {100 * r.min_radius, 100 * r.max_radius};
        j["steps"] = r.steps;
        if (!out.empty()) {
          std::string obj;
          for (const Vec3& p : r.positions) obj += fmt::format("v {:.9g} {:.9g} {:.9g}\n", p.x, p.y, p.z);
          for (size_t t = 0; t < r.triangles.size(); t += 3)
            obj += fmt::format("f {} {} {}\n", r.triangles[t] + 1, r.triangles[t + 1] + 1, r.triangles[t + 2] + 1);
          write_text(out / "drape.obj", obj);
        }
      } else if (!m.measured.empty()) {
        // A measured fabric: pulled along each direction, held across, against the measured model.
        lab::DirectionalOptions o;
        if (a->settle > 0) o.stepping.settle = a->settle;
        o.stepping.dt = a->dt;
        o.grid = !a->triangles;
        o.edge = a->edge;
        std::string csv = "angle_deg,strain,tension_N_per_m,measured_N_per_m\n";
        for (double angle : a->angles) {
          for (const lab::DirectionalPoint& p : lab::directional_tensile(m, angle, o)) {
            csv += fmt::format("{:g},{:.6g},{:.6g},{:.6g}\n", p.angle, p.strain, p.tension, p.measured);
            j["curve"].push_back({{"angle_deg", p.angle}, {"strain", p.strain}, {"tension_N_per_m", p.tension},
                                  {"measured_N_per_m", p.measured}, {"edge_mm", 1e3 * p.edge}});
            std::cout << fmt::format("{}: {:g} degrees from the warp, strain {:.2f} %: {:.2f} N/m (measured model {:.2f} N/m, {:+.1f} %), {} of {:.2g} mm\n",
                                     a->fabric, p.angle, 100 * p.strain, p.tension, p.measured, 100 * (p.tension / p.measured - 1),
                                     o.grid ? "cells" : "triangles", 1e3 * p.edge);
          }
        }
        if (!out.empty()) write_text(out / "tensile.csv", csv);
      } else {
        lab::TensileOptions o;
        o.stepping = st;
        const double emt = m.fabric->EMT / 100.0;
        o.strains.clear();
        for (int i = 1; i <= 5; ++i) o.strains.push_back(emt * i / 5);
        const auto curve = lab::tensile_test(m, o);
        std::string csv = "strain,stress_N_per_m,stress_gf_per_cm\n";
        for (const auto& p : curve) {
          csv += fmt::format("{:.6g},{:.6g},{:.6g}\n", p.strain, p.stress, p.stress * 1e-2 / fabric::kGramForce);
          j["curve"].push_back({{"strain", p.strain}, {"stress_N_per_m", p.stress}});
        }
        if (!a->quiet) std::cout << csv;
        const double at_emt = curve.back().stress * 1e-2 / fabric::kGramForce;
        std::cout << fmt::format("{}: {:.0f} gf/cm at EMT = {:.2f} % (KES-F: 500 gf/cm there; {:+.1f} %), triangles of {:.2g} mm\n",
                                 a->fabric, at_emt, m.fabric->EMT, 100 * (at_emt / fabric::kKesMaxLoad - 1), 1e3 * curve.back().edge);
        j["edge_mm"] = 1e3 * curve.back().edge;
        if (!out.empty()) write_text(out / "tensile.csv", csv);
      }
      j["wall_seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      if (!out.empty()) write_text(out / "result.json", j.dump(2) + "\n");
      return 0;
    });
  };
}

}  // namespace raycloth::cli
