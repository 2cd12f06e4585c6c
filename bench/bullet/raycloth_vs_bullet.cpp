// raycloth_vs_bullet: the peers' scene (bench/peers_drape.json: a 1 m cloth of 65 x 65 vertices
// dropped over a 578-vertex UV sphere of radius 0.25 m, 2 simulated seconds) run by raycloth and by
// Bullet's classic soft body (btSoftRigidDynamicsWorld), one after the other in this one process, so
// that the ratios come from one run on one machine.
//
// Bullet is built from the same scene definition: CreatePatch with the panel's size, resolution and
// height, the sphere as the same UV-sphere triangle set (make_uv_sphere) in a btConvexHullShape, the
// same gravity, total mass, friction and damping rate. It steps at its own dt (1 ms by default) with
// one thread, twice: without self-collision and with it. Bullet 3.24's classic soft body has
// self-collision only between clusters (CL_SS with CL_SELF), and its collision handler switches on
// the soft-soft bits with CL_SELF among them, so that combination matches no case and nothing
// collides; SelfCollidingWorld below calls the cluster collider itself at the place in the step
// where btSoftRigidDynamicsWorld would.
//
// After each run the final cloth goes through raycloth's exact check (check/exact_check.h): cloth
// edges through cloth triangles and cloth vertices inside the sphere's triangle mesh.
#include <btBulletDynamicsCommon.h>
#include <BulletSoftBody/btDefaultSoftBodySolver.h>
#include <BulletSoftBody/btSoftBodyHelpers.h>
#include <BulletSoftBody/btSoftBodyInternals.h>
#include <BulletSoftBody/btSoftBodyRigidBodyCollisionConfiguration.h>
#include <BulletSoftBody/btSoftRigidDynamicsWorld.h>
#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <sys/resource.h>

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <cmath>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "check/exact_check.h"
#include "sim/model_check.h"
#include "io/atomic_file.h"
#include "raycloth/error.h"
#include "raycloth/scene.h"
#include "raycloth/simulator.h"
#include "scene/mesh.h"

namespace {

using namespace raycloth;

double cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

struct Result {
  std::string name;
  double dt = 0;
  long steps = 0;
  int threads = 1;
  double setup_wall = 0;  // building the world or the simulator
  double wall = 0;        // setup and all steps
  double cpu = 0;         // process CPU time over the same span, all threads
  size_t crossings = 0, inside = 0;  // exact check of the final state
  double stretch_mean = 0, stretch_max = 0;  // relative length change of the grid's u and v edges at the end
  std::string note;
  double steps_per_s() const { return double(steps) / wall; }
  double sim_per_wall() const { return double(steps) * dt / wall; }
};

// Stretch of the grid edges (rest length width / (nu - 1) along u, height / (nv - 1) along v) of a
// cloth whose vertex (u, v) is at index v * nu + u.
void grid_stretch(const std::vector<Vec3>& x, int nu, int nv, float width, float height, Result& r) {
  double sum = 0, worst = 0;
  long n = 0;
  auto edge = [&](int a, int b, double rest) {
    const Vec3 d = x[size_t(b)] - x[size_t(a)];
    const double s = std::abs(std::sqrt(double(d.x) * d.x + double(d.y) * d.y + double(d.z) * d.z) / rest - 1.0);
    sum += s, worst = std::max(worst, s), ++n;
  };
  for (int v = 0; v < nv; ++v)
    for (int u = 0; u + 1 < nu; ++u) edge(v * nu + u, v * nu + u + 1, width / double(nu - 1));
  for (int v = 0; v + 1 < nv; ++v)
    for (int u = 0; u < nu; ++u) edge(v * nu + u, (v + 1) * nu + u, height / double(nv - 1));
  r.stretch_mean = sum / double(n), r.stretch_max = worst;
}

struct PeerScene {
  SceneDef def;
  const PanelDef* panel = nullptr;
  const MaterialDef* material = nullptr;
  const ObstacleDef* sphere = nullptr;
};

PeerScene peer_scene(const std::string& file) {
  PeerScene s;
  s.def = load_scene_file(file);
  auto fail = [&](const std::string& why) { throw InputError(file, "", why); };
  if (s.def.panels.size() != 1 || s.def.panels[0].shape != PanelShape::Rectangle)
    fail("this benchmark needs exactly one rectangular panel");
  if (s.def.obstacles.size() != 1 || s.def.obstacles[0].type != ObstacleType::UvSphere || s.def.obstacles[0].motion)
    fail("this benchmark needs exactly one resting uv_sphere obstacle");
  s.panel = &s.def.panels[0];
  s.sphere = &s.def.obstacles[0];
  for (const MaterialDef& m : s.def.materials)
    if (m.name == s.panel->material) s.material = &m;
  if (!s.material) fail("the panel's material is not defined");
  const TransformDef& pt = s.panel->transform;
  if (pt.rotation != Float3{0, 0, 0} || pt.scale != Float3{1, 1, 1}) fail("the panel must be horizontal and unscaled");
  if (s.sphere->transform.rotation != Float3{0, 0, 0} || s.sphere->transform.scale != Float3{1, 1, 1})
    fail("the sphere must be neither rotated nor scaled");
  return s;
}

// The sphere in world space as the exact check wants it.
CheckMesh sphere_check_mesh(const PeerScene& s) {
  const TriMesh m = make_uv_sphere(s.sphere->radius, s.sphere->slices, s.sphere->stacks);
  const Float3& p = s.sphere->transform.position;
  CheckMesh c;
  for (const Vec3& v : m.vertices) c.vertices.push_back(v + make_vec3(p[0], p[1], p[2]));
  c.triangles = m.indices;
  c.group_names = {s.sphere->name};
  c.group_first_triangle = {0};
  return c;
}

Result run_raycloth(const PeerScene& s, const std::string& device) {
  Result r;
  r.name = "raycloth";
  r.note = "";
  r.dt = s.def.time.dt;
  r.threads = int(std::thread::hardware_concurrency());
  const double c0 = cpu_seconds();
  const auto t0 = std::chrono::steady_clock::now();
  SimOptions options;
  options.device = device;
  Simulator sim(s.def, options);
  r.setup_wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.steps = std::lround(s.def.time.duration / s.def.time.dt);
  sim.step(int(r.steps));
  const std::vector<Vec3>& x = sim.positions();
  r.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.cpu = cpu_seconds() - c0;
  const CheckReport check =
      check_state(cloth_check_mesh(sim.model(), x), obstacle_check_mesh(sim.obstacles(), sim.obstacle_vertices()));
  r.crossings = check.crossings, r.inside = check.vertices_inside;
  grid_stretch(x, s.panel->resolution_u, s.panel->resolution_v, s.panel->width, s.panel->height, r);
  r.note = fmt::format("cloth-cloth {}, device {}", s.def.collision.cloth_cloth ? "on" : "off", sim.device());
  return r;
}

// btSoftRigidDynamicsWorld's step with the soft body's cluster self-collision called directly (see
// the top of the file); without self-collision it is Bullet's own step.
class SelfCollidingWorld : public btSoftRigidDynamicsWorld {
 public:
  SelfCollidingWorld(btDispatcher* d, btBroadphaseInterface* b, btConstraintSolver* c, btCollisionConfiguration* cc,
                     btSoftBodySolver* soft, bool cluster_self)
      : btSoftRigidDynamicsWorld(d, b, c, cc, soft), soft_(soft), cluster_self_(cluster_self) {}
  size_t self_contacts = 0;  // cluster joints the self-collision made, summed over steps

 protected:
  void internalSingleStepSimulation(btScalar dt) override {
    if (!cluster_self_) {
      btSoftRigidDynamicsWorld::internalSingleStepSimulation(dt);
      return;
    }
    soft_->optimize(getSoftBodyArray());
    soft_->checkInitialized();
    btDiscreteDynamicsWorld::internalSingleStepSimulation(dt);
    solveSoftBodiesConstraints(dt);
    for (int i = 0; i < getSoftBodyArray().size(); ++i) {
      btSoftBody* psb = getSoftBodyArray()[i];
      const int before = psb->m_joints.size();
      btSoftColliders::CollideCL_SS collide;
      collide.ProcessSoftSoft(psb, psb);
      self_contacts += size_t(psb->m_joints.size() - before);
    }
    soft_->updateSoftBodies();
    for (int i = 0; i < getSoftBodyArray().size(); ++i) getSoftBodyArray()[i]->interpolateRenderMesh();
  }

 private:
  btSoftBodySolver* soft_;
  bool cluster_self_;
};

struct BulletOptions {
  double dt = 1e-3;
  int piterations = 4;
  int clusters = 0;           // generateClusters(k) for self-collision; 0: one cluster per triangle
  double margin = 0.005;      // soft body collision margin, metres
  double voxel = 0.025;       // sparse SDF voxel size, metres (Bullet's default is 0.25)
  double bend_stiffness = 0.2;  // kLST of the bending links (stretch and shear links: 1)
};

Result run_bullet(const PeerScene& s, const BulletOptions& o, bool self_collision) {
  Result r;
  r.name = self_collision ? "Bullet, self-collision" : "Bullet";
  r.dt = o.dt;
  r.steps = std::lround(s.def.time.duration / o.dt);
  const double c0 = cpu_seconds();
  const auto t0 = std::chrono::steady_clock::now();

  btSoftBodyRigidBodyCollisionConfiguration config;
  btCollisionDispatcher dispatcher(&config);
  btDbvtBroadphase broadphase;
  btSequentialImpulseConstraintSolver solver;
  btDefaultSoftBodySolver soft_solver;
  SelfCollidingWorld world(&dispatcher, &broadphase, &solver, &config, &soft_solver, self_collision);
  const Float3& g = s.def.gravity;
  world.setGravity(btVector3(g[0], g[1], g[2]));
  btSoftBodyWorldInfo& info = world.getWorldInfo();
  info.m_gravity = world.getGravity();
  info.m_sparsesdf.Initialize();
  info.m_sparsesdf.setDefaultVoxelsz(btScalar(o.voxel));
  info.m_sparsesdf.Reset();

  // The sphere: the same vertices as raycloth's, as a static convex hull.
  const TriMesh sphere = make_uv_sphere(s.sphere->radius, s.sphere->slices, s.sphere->stacks);
  btConvexHullShape hull;
  for (const Vec3& v : sphere.vertices) hull.addPoint(btVector3(v.x, v.y, v.z), false);
  hull.recalcLocalAabb();
  hull.setMargin(0.001f);
  const Float3& sp = s.sphere->transform.position;
  btTransform sphere_at;
  sphere_at.setIdentity();
  sphere_at.setOrigin(btVector3(sp[0], sp[1], sp[2]));
  btDefaultMotionState motion(sphere_at);
  btRigidBody body(btRigidBody::btRigidBodyConstructionInfo(0, &motion, &hull));
  body.setFriction(s.def.collision.friction);
  world.addRigidBody(&body);

  // The cloth: u along x, v along z, centred on the panel's position, 2 triangles per quad.
  const PanelDef& p = *s.panel;
  const Float3& c = p.transform.position;
  const float hw = 0.5f * p.width, hh = 0.5f * p.height;
  btSoftBody* cloth = btSoftBodyHelpers::CreatePatch(
      info, btVector3(c[0] - hw, c[1], c[2] - hh), btVector3(c[0] + hw, c[1], c[2] - hh),
      btVector3(c[0] - hw, c[1], c[2] + hh), btVector3(c[0] + hw, c[1], c[2] + hh), p.resolution_u, p.resolution_v,
      0, true);
  std::unique_ptr<btSoftBody> owned(cloth);
  cloth->getCollisionShape()->setMargin(btScalar(o.margin));
  cloth->m_materials[0]->m_kLST = 1;  // structural and shear (diagonal) links
  btSoftBody::Material* bend = cloth->appendMaterial();
  bend->m_kLST = btScalar(o.bend_stiffness);
  cloth->generateBendingConstraints(2, bend);
  cloth->setTotalMass(btScalar(s.material->density * p.width * p.height));
  cloth->m_cfg.piterations = o.piterations;
  cloth->m_cfg.kDF = s.def.collision.friction;
  cloth->m_cfg.kDP = btScalar(std::min(1.0, double(s.material->damping) * o.dt));  // the same rate, per step
  cloth->m_cfg.collisions = btSoftBody::fCollision::SDF_RS;
  if (self_collision) {
    cloth->m_cfg.collisions |= btSoftBody::fCollision::CL_SS | btSoftBody::fCollision::CL_SELF;
    cloth->generateClusters(o.clusters);
  }
  world.addSoftBody(cloth);
  r.setup_wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  for (long i = 0; i < r.steps; ++i) world.stepSimulation(btScalar(o.dt), 0, btScalar(o.dt));

  r.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.cpu = cpu_seconds() - c0;

  CheckMesh mesh;
  const btSoftBody::Node* first = &cloth->m_nodes[0];
  for (int i = 0; i < cloth->m_nodes.size(); ++i) {
    const btVector3& x = cloth->m_nodes[i].m_x;
    mesh.vertices.push_back(make_vec3(float(x.x()), float(x.y()), float(x.z())));
  }
  for (int f = 0; f < cloth->m_faces.size(); ++f)
    for (int k = 0; k < 3; ++k) mesh.triangles.push_back(uint32_t(cloth->m_faces[f].m_n[k] - first));
  const CheckReport check = check_state(mesh, sphere_check_mesh(s));
  r.crossings = check.crossings, r.inside = check.vertices_inside;
  grid_stretch(mesh.vertices, p.resolution_u, p.resolution_v, p.width, p.height, r);
  r.note = fmt::format("piterations {}, margin {} m", o.piterations, o.margin);
  if (self_collision)
    r.note += fmt::format(", {} clusters, {} self-contact joints", cloth->m_clusters.size(), world.self_contacts);

  world.removeSoftBody(cloth);
  world.removeRigidBody(&body);
  return r;
}

// Blender's cloth (Debian `blender`, headless) on the same scene: bench/blender/peers_drape.py builds
// the cloth and sphere from the same numbers, steps frame by frame with self-collision and writes
// the final cloth; the wall time is the script's own timing of the frames (Blender's start-up, about
// a second, goes to setup). The final cloth then goes through the same exact check and stretch.
struct BlenderOptions {
  std::string program = "blender";
  int quality = 5;
  double self_distance = 0.005;
};

Result run_blender(const PeerScene& s, const BlenderOptions& o) {
  Result r;
  r.name = "Blender cloth";
  r.threads = int(std::thread::hardware_concurrency());
  const PanelDef& p = *s.panel;
  if (p.width != p.height || p.resolution_u != p.resolution_v)
    throw InputError("", "", "the Blender side needs a square panel with as many vertices along u as along v");
  const std::string out =
      (std::filesystem::temp_directory_path() / fmt::format("raycloth_vs_blender_{}.json", ::getpid())).string();
  const int fps = 30;
  const std::string cmd = fmt::format(
      "'{}' -b --factory-startup --python-exit-code 1 --python '{}/bench/blender/peers_drape.py' -- --size {} "
      "--resolution {} --height {} --radius {} --slices {} --stacks {} --friction {} --duration {} --fps {} "
      "--quality {} --self-distance {} --out '{}' > '{}.log' 2>&1",
      o.program, RAYCLOTH_SOURCE_DIR, p.width, p.resolution_u, p.transform.position[1] - s.sphere->transform.position[1],
      s.sphere->radius, s.sphere->slices, s.sphere->stacks,
      s.def.collision.friction, s.def.time.duration, fps, o.quality, o.self_distance, out, out);
  const auto t0 = std::chrono::steady_clock::now();
  const int status = std::system(cmd.c_str());
  const double process_wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (status != 0) {
    std::ifstream log(out + ".log");
    std::stringstream text;
    text << log.rdbuf();
    throw InputError(o.program, "", fmt::format("Blender failed (status {}); its output:\n{}", status, text.str()));
  }
  std::ifstream in(out);
  const nlohmann::json j = nlohmann::json::parse(in);
  std::filesystem::remove(out);
  std::filesystem::remove(out + ".log");
  r.steps = j.at("steps").get<long>();
  r.dt = s.def.time.duration / double(r.steps);
  r.wall = j.at("wall_s").get<double>();
  r.setup_wall = process_wall - r.wall;
  // Blender runs in a child process: its CPU time is the children's.
  rusage u{};
  getrusage(RUSAGE_CHILDREN, &u);
  r.cpu = double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
  CheckMesh mesh;
  for (const auto& v : j.at("vertices")) mesh.vertices.push_back(make_vec3(v[0].get<float>(), v[1].get<float>(), v[2].get<float>()));
  for (const auto& t : j.at("triangles"))
    for (int k = 0; k < 3; ++k) mesh.triangles.push_back(t[size_t(k)].get<uint32_t>());
  const CheckReport check = check_state(mesh, sphere_check_mesh(s));
  r.crossings = check.crossings, r.inside = check.vertices_inside;
  grid_stretch(mesh.vertices, p.resolution_u, p.resolution_v, p.width, p.height, r);
  r.note = fmt::format("Blender {}, quality {} ({} steps per frame at {} fps), self-collision distance {} m; "
                       "whole process {:.2f} s", j.at("blender").get<std::string>(), o.quality, o.quality, fps,
                       o.self_distance, process_wall);
  return r;
}

// The program's path when it is on PATH (or given with a slash and executable), else empty.
bool program_found(const std::string& program) {
  return std::system(fmt::format("command -v '{}' > /dev/null 2>&1", program).c_str()) == 0;
}

nlohmann::json to_json(const Result& r) {
  return {{"name", r.name},     {"dt", r.dt},
          {"steps", r.steps},   {"threads", r.threads},
          {"setup_wall_s", r.setup_wall}, {"wall_s", r.wall},
          {"cpu_s", r.cpu},     {"steps_per_s", r.steps_per_s()},
          {"sim_s_per_wall_s", r.sim_per_wall()}, {"crossings", r.crossings},
          {"vertices_inside", r.inside}, {"stretch_mean", r.stretch_mean},
          {"stretch_max", r.stretch_max}, {"note", r.note}};
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"raycloth and Bullet's classic soft body on the peers' scene, in one process"};
  std::string scene_file = std::string(RAYCLOTH_SOURCE_DIR) + "/bench/peers_drape.json";
  std::string json_file;
  BulletOptions bo;
  bool skip_self = false;
  BlenderOptions blender;
  bool skip_blender = false;
  std::vector<std::string> also;
  std::string device = "cpu";
  app.add_option("--device", device, "raycloth's device: cpu, cuda or auto (Bullet and Blender run on the CPU)")
      ->check(CLI::IsMember({"cpu", "cuda", "auto"}));
  app.add_option("--scene", scene_file, "Scene file (one rectangular panel over one uv_sphere)");
  app.add_option("--json", json_file, "Also write the results as JSON to this file");
  app.add_option("--bullet-dt", bo.dt, "Bullet's time step, seconds")->check(CLI::Range(1e-5, 0.05));
  app.add_option("--piterations", bo.piterations, "Bullet's position solver iterations")->check(CLI::Range(1, 1000));
  app.add_option("--clusters", bo.clusters, "Bullet's clusters for self-collision (0: one per triangle)")
      ->check(CLI::Range(0, 1000000));
  app.add_flag("--no-bullet-self", skip_self, "Skip Bullet with self-collision");
  app.add_option("--also", also, "Further raycloth scenes of the same geometry to run after the first "
                                 "(e.g. bench/peers_drape_implicit.json)");
  app.add_option("--blender", blender.program, "Blender's program (Debian's `blender`); skipped when not found");
  app.add_option("--blender-quality", blender.quality, "Blender's cloth steps per frame")->check(CLI::Range(1, 100));
  app.add_flag("--no-blender", skip_blender, "Skip Blender");
  CLI11_PARSE(app, argc, argv);
  spdlog::set_level(spdlog::level::warn);

  try {
    const PeerScene scene = peer_scene(scene_file);
    std::cout << fmt::format("scene {}: {} x {} cloth vertices, sphere of {} vertices, {} simulated s\n",
                             scene_file, scene.panel->resolution_u, scene.panel->resolution_v,
                             make_uv_sphere(scene.sphere->radius, scene.sphere->slices, scene.sphere->stacks)
                                 .vertices.size(),
                             scene.def.time.duration);
    std::vector<Result> results;
    auto report = [&](const Result& r) {
      std::cout << fmt::format("{:<24} done: {:.2f} s wall, {} crossings, {} vertices inside\n", r.name, r.wall,
                               r.crossings, r.inside)
                << std::flush;
      results.push_back(r);
    };
    report(run_raycloth(scene, device));
    for (const std::string& file : also) {
      Result r = run_raycloth(peer_scene(file), device);
      r.name = fmt::format("raycloth ({})", std::filesystem::path(file).stem().string());
      report(r);
    }
    report(run_bullet(scene, bo, false));
    if (!skip_self) report(run_bullet(scene, bo, true));
    if (!skip_blender) {
      if (program_found(blender.program))
        report(run_blender(scene, blender));
      else
        std::cout << fmt::format("Blender skipped: `{}` not found (Debian package `blender`)\n", blender.program);
    }

    std::cout << fmt::format("\n{:<32} {:>8} {:>6} {:>8} {:>8} {:>8} {:>9} {:>8} {:>9} {:>7} {:>9} {:>9}\n", "", "dt ms",
                             "thr", "steps", "wall s", "CPU s", "steps/s", "sim s/s", "crossings", "inside",
                             "stretch", "max str.");
    for (const Result& r : results)
      std::cout << fmt::format("{:<32} {:>8.2f} {:>6} {:>8} {:>8.2f} {:>8.2f} {:>9.0f} {:>8.3f} {:>9} {:>7} {:>8.2f}% {:>8.2f}%\n",
                               r.name, 1e3 * r.dt, r.threads, r.steps, r.wall, r.cpu, r.steps_per_s(),
                               r.sim_per_wall(), r.crossings, r.inside, 100 * r.stretch_mean, 100 * r.stretch_max);
    for (const Result& r : results) std::cout << fmt::format("  {}: setup {:.2f} s; {}\n", r.name, r.setup_wall, r.note);
    nlohmann::json ratios = nlohmann::json::object();
    // Every raycloth run against every peer: wall and CPU time for the same simulated time.
    for (const Result& a : results) {
      if (a.name.rfind("raycloth", 0) != 0) continue;
      for (const Result& b : results) {
        if (b.name.rfind("raycloth", 0) == 0) continue;
        const double wall = a.wall / b.wall, cpu = a.cpu / b.cpu;
        std::cout << fmt::format("{} / {}: wall {:.3f}, CPU {:.3f}\n", a.name, b.name, wall, cpu);
        ratios[a.name][b.name] = {{"wall", wall}, {"cpu", cpu}};
      }
    }
    if (!json_file.empty()) {
      nlohmann::json out = {{"scene", scene_file}, {"runs", nlohmann::json::array()}, {"raycloth_over", ratios}};
      for (const Result& r : results) out["runs"].push_back(to_json(r));
      // Whole or not at all: a failed write names the file and leaves no partial JSON behind.
      write_file_atomically(json_file, [&](std::ostream& f) { f << out.dump(2) << "\n"; });
    }
  } catch (const std::exception& e) {
    std::cerr << "raycloth_vs_bullet: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
