// session::Run. See run.h.
#include "dentar/session/run.h"

#include <nlohmann/json.hpp>

#include "dentar/haptics/session_log.h"
#include "dentar/training/exercise.h"
#include "dentar/volume/procedural_tooth.h"

namespace dentar::session {

Result<volume::VoxelVolume> tooth_from_header(const std::string& tooth_json, std::uint64_t start_hash,
                                              const std::string& log_path) {
  auto j = nlohmann::json::parse(tooth_json, nullptr, false);
  if (j.is_discarded() || !j.is_object() || !j.contains("voxel_mm") || !j["voxel_mm"].is_number())
    return Error{log_path + ": header field tooth = " + tooth_json +
                 " does not describe a tooth this build can rebuild ({\"kind\": \"molar\"|\"incisor\", \"voxel_mm\": ...})"};
  auto v = training::make_start_tooth(tooth_json, start_hash);
  if (!v) return Error{log_path + ": header field tooth: " + v.error()};
  return v;
}

Result<SessionLogSetup> read_session_setup(const std::string& path) {
  auto log = haptics::read_session_log(path);
  if (!log) return Error{log.error()};
  auto setup = haptics::parse_session_header(log->header_json);
  if (!setup) return Error{path + ": " + setup.error()};
  SessionLogSetup s;
  s.path = path;
  s.setup = std::move(*setup);
  s.records = std::move(log->records);
  s.tooth_json = s.setup.tooth_json;
  s.warning = log->warning;
  return s;
}

Run::~Run() {
  // The pipeline and meshes before the volume they draw; the engine before its device.
  pipeline_.reset();
  meshes_.reset();
  engine_.reset();
  log_.reset();
  lesson_.reset();
}

Result<std::unique_ptr<Run>> Run::from_station(const ar::StationScene& station) {
  std::unique_ptr<Run> run(new Run);
  volume::MolarParams mp;
  mp.voxel_mm = station.tooth_voxel_m * 1e3;
  auto tooth = volume::make_molar(mp);
  if (!tooth) return Error{"tooth: " + tooth.error()};
  run->volume_.emplace(std::move(*tooth));
  return run;
}

Result<std::unique_ptr<Run>> Run::from_session_log(SessionLogSetup log, const ar::StationScene& station,
                                                   const std::string& station_name) {
  std::unique_ptr<Run> run(new Run);
  const haptics::SessionSetup& setup = log.setup;
  auto tooth = tooth_from_header(setup.tooth_json, setup.volume_hash_start, log.path);
  if (!tooth) return Error{tooth.error()};
  run->volume_.emplace(std::move(*tooth));
  if (run->volume_->content_hash() != setup.volume_hash_start)
    return Error{log.path + ": the rebuilt tooth does not match the log's volume_hash_start "
                 "(the log was recorded on another tooth or another build)"};
  auto samples = volume::sample_bur(setup.bur, setup.bur_samples);
  if (!samples) return Error{log.path + ": bur: " + samples.error()};
  run->bur_.emplace(std::move(*samples));
  if ((station.calibration.T_tooth_dev().matrix() - setup.engine.T_tooth_dev.matrix()).norm() > 1e-6)
    run->warnings_.push_back(log.path + " was recorded with another station registration (T_tooth_dev) than " +
                             station_name + ": the bur is drawn with the station's");
  run->session_steps_ = log.records.size();
  run->replay_ = std::make_unique<haptics::ReplayDevice>(std::move(log.records), setup.limits);
  haptics::EngineConfig cfg = setup.engine;
  cfg.try_realtime = false;
  if (setup.training) {  // a lesson's session: its mode, rebuilt from the expert's recording
    auto lesson = LessonClock::from_header(*setup.training);
    if (!lesson) return Error{log.path + ": training: " + lesson.error()};
    run->lesson_ = std::move(*lesson);
    for (const std::string& n : run->lesson_->notes()) run->warnings_.push_back(log.path + ": " + n);
    cfg.training = run->lesson_->mode();
  }
  auto eng = haptics::Engine::create(cfg, *run->replay_, *run->volume_, *run->bur_, nullptr);
  if (!eng) return Error{log.path + ": " + eng.error()};
  run->engine_ = std::move(*eng);
  run->setup_ = setup;
  return run;
}

std::unique_ptr<Run> Run::from_tooth(volume::VoxelVolume tooth, volume::BurSamples bur) {
  std::unique_ptr<Run> run(new Run);
  run->volume_.emplace(std::move(tooth));
  run->bur_.emplace(std::move(bur));
  return run;
}

Status Run::make_engine(const haptics::EngineConfig& config, haptics::HapticDevice& device, const std::string& tooth_json,
                        const std::string& log_path) {
  haptics::EngineConfig cfg = config;
  if (lesson_) cfg.training = lesson_->mode();
  if (!log_path.empty()) {
    // The header is the engine's own: a probe engine writes it, the log opens with it.
    std::string header;
    {
      auto probe = haptics::Engine::create(cfg, device, *volume_, *bur_, nullptr);
      if (!probe) return Error{"engine: " + probe.error()};
      header = (*probe)->header_json(tooth_json);
    }
    auto w = haptics::SessionLogWriter::open(log_path, header);
    if (!w) return Error{w.error()};
    log_ = std::move(*w);
  }
  auto eng = haptics::Engine::create(cfg, device, *volume_, *bur_, log_.get());
  if (!eng) return Error{"engine: " + eng.error()};
  engine_ = std::move(*eng);
  return {};
}

Status Run::close_session_log() { return log_ ? log_->close() : Status{}; }

Status Run::make_pipeline(const ar::StationScene& station, const ar::PipelineOptions& options) {
  if (auto s = create_pipeline(station, options); !s) return s;
  return warm_up();
}

Status Run::create_pipeline(const ar::StationScene& station, const ar::PipelineOptions& options) {
  meshes_ = std::make_unique<ar::ToothMeshes>(*volume_);
  auto p = ar::FramePipeline::create(station, options);
  if (!p) return Error{p.error()};
  pipeline_ = std::move(*p);
  return {};
}

Status Run::warm_up(const ar::GlFrameTarget& target) { return pipeline_->warm_up(*meshes_, target); }

void Run::drop_pipeline() {
  pipeline_.reset();
  meshes_.reset();
}

Status Run::record_to(const std::string& dir, bool stereo) {
  auto r = Recorder::open(dir, stereo);
  if (!r) return Error{r.error()};
  recorder_ = std::move(*r);
  return {};
}

}  // namespace dentar::session
