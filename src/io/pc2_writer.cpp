#include "io/pc2_writer.h"

#include <fmt/format.h>

#include <bit>
#include <cerrno>
#include <cstring>
#include <stdexcept>

#include "io/atomic_file.h"
#include "io/checkpoint.h"
#include "raycloth/error.h"
#include "sim/model.h"

namespace raycloth {

static_assert(std::endian::native == std::endian::little, "PC2 files are little-endian");

namespace {
constexpr std::streamoff kNumSamplesOffset = 28;  // 12-byte signature, 4 x 4-byte fields before it

template <typename T>
void put(std::ofstream& out, const T& v) {
  out.write(reinterpret_cast<const char*>(&v), sizeof(T));
}

void write_rest_obj(const std::filesystem::path& path, const ClothModel& model, const std::vector<Vec3>& x) {
  write_file_atomically(path, [&](std::ostream& out) {
    fmt::memory_buffer buf;
    fmt::format_to(std::back_inserter(buf),
                   "# raycloth rest pose: vertex order is the point order of cloth.pc2 ({} vertices)\no cloth\n",
                   x.size());
    for (const Vec3& p : x) fmt::format_to(std::back_inserter(buf), "v {:.6f} {:.6f} {:.6f}\n", p.x, p.y, p.z);
    for (size_t t = 0; t < model.triangles.size(); t += 3)
      fmt::format_to(std::back_inserter(buf), "f {} {} {}\n", model.triangles[t] + 1, model.triangles[t + 1] + 1,
                     model.triangles[t + 2] + 1);
    out.write(buf.data(), std::streamsize(buf.size()));
  });
}
}  // namespace

Pc2File::Pc2File(std::filesystem::path path, uint32_t num_points, float start_frame, float sample_rate)
    : path_(std::move(path)), num_points_(num_points) {
  tmp_ = path_;
  tmp_ += ".tmp";
  out_.open(tmp_, std::ios::binary | std::ios::trunc);
  if (!out_) throw std::runtime_error(path_.string() + ": cannot write: " + std::strerror(errno));
  out_.write("POINTCACHE2\0", 12);
  put(out_, int32_t(1));
  put(out_, int32_t(num_points_));
  put(out_, start_frame);
  put(out_, sample_rate);
  put(out_, int32_t(0));  // numSamples, written by finish()
}

Pc2File::~Pc2File() = default;

std::unique_ptr<Pc2File> Pc2File::reopen(std::filesystem::path path, uint32_t num_points, uint32_t num_samples) {
  std::unique_ptr<Pc2File> f(new Pc2File());
  f->path_ = std::move(path);
  f->tmp_ = f->path_;
  f->tmp_ += ".tmp";
  f->num_points_ = num_points;
  f->num_samples_ = num_samples;
  const uintmax_t want = uintmax_t(kNumSamplesOffset) + 4 + uintmax_t(num_samples) * num_points * sizeof(Vec3);
  std::error_code ec;
  const uintmax_t have = std::filesystem::file_size(f->tmp_, ec);
  if (ec || have < want)
    throw InputError(f->tmp_.string(), "", fmt::format("holds fewer than the {} samples the checkpoint counts ({}); start "
                                                       "the run again without --resume",
                                                       num_samples, ec ? ec.message() : std::to_string(have) + " bytes"));
  std::filesystem::resize_file(f->tmp_, want, ec);
  if (ec) throw std::runtime_error(f->tmp_.string() + ": cannot cut to the checkpoint: " + ec.message());
  f->out_.open(f->tmp_, std::ios::binary | std::ios::in | std::ios::out);
  f->out_.seekp(0, std::ios::end);
  if (!f->out_) throw std::runtime_error(f->path_.string() + ": cannot write: " + std::strerror(errno));
  return f;
}

void Pc2File::add_sample(const std::vector<Vec3>& points) {
  if (points.size() != num_points_)
    throw std::logic_error(fmt::format("{}: sample of {} points, expected {}", path_.string(), points.size(), num_points_));
  static_assert(sizeof(Vec3) == 12);
  out_.write(reinterpret_cast<const char*>(points.data()), std::streamsize(points.size() * sizeof(Vec3)));
  if (!out_) throw std::runtime_error(path_.string() + ": write failed: " + std::strerror(errno));
  ++num_samples_;
}

void Pc2File::flush() {
  out_.flush();
  if (!out_) throw std::runtime_error(path_.string() + ": write failed: " + std::strerror(errno));
}

void Pc2File::finish() {
  if (finished_) return;
  finished_ = true;
  out_.seekp(kNumSamplesOffset);
  put(out_, int32_t(num_samples_));
  out_.close();
  if (!out_) throw std::runtime_error(path_.string() + ": write failed: " + std::strerror(errno));
  std::error_code ec;
  std::filesystem::rename(tmp_, path_, ec);
  if (ec) throw std::runtime_error(path_.string() + ": cannot rename from " + tmp_.string() + ": " + ec.message());
}

void Pc2Sink::begin(Simulator& sim, const std::filesystem::path& out) {
  out_dir_ = out;
  file_ = std::make_unique<Pc2File>(out / "cloth.pc2", sim.model().num_vertices());
}

void Pc2Sink::frame(Simulator& sim, const FrameRecord& r) {
  if (r.index == 0) write_rest_obj(out_dir_ / "cloth_rest.obj", sim.model(), sim.positions());
  file_->add_sample(sim.positions());
}

void Pc2Sink::end(Simulator&) {
  if (file_) file_->finish();
}

void Pc2Sink::save(ByteWriter& out) {
  file_->flush();
  out.u32(file_->num_samples());
}

void Pc2Sink::resume(Simulator& sim, const std::filesystem::path& out, ByteReader& in) {
  out_dir_ = out;
  file_ = Pc2File::reopen(out / "cloth.pc2", sim.model().num_vertices(), in.u32());
}

}  // namespace raycloth
