// session::Run. See run.h.
#include "dentar/session/run.h"

#include <nlohmann/json.hpp>

#include "dentar/haptics/session_log.h"
#include "dentar/training/exercise.h"
#include "dentar/volume/procedural_tooth.h"

namespace dentar::session {

Result<volume::VoxelVolume> tooth_from_header(const std::string& tooth_json, const std::string& log_path) {
  auto j = nlohmann::json::parse(tooth_json, nullptr, false);
  if (j.is_discarded() || !j.is_object() || !j.contains("voxel_mm") || !j["voxel_mm"].is_number())
    return Error{log_path + ": header field tooth = " + tooth_json +
                 " does not describe a tooth this build can rebuild ({\"kind\": \"molar\"|\"incisor\", \"voxel_mm\": ...})"};
  auto v = training::make_tooth(tooth_json);
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
  auto tooth = tooth_from_header(setup.tooth_json, log.path);
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
  if (setup.training) {
    const haptics::TrainingSetup& t = *setup.training;
    auto expert = haptics::read_session_log(t.params.expert_file);
    if (!expert)
      return Error{log.path + ": the session was trained on " + t.params.expert_file + ": " + expert.error()};
    auto tr = haptics::ExpertTrack::from_records(expert->records, t.expert_T_tooth_dev, t.expert_T_sty_tip,
                                                 t.params.expert_file);
    if (!tr) return Error{log.path + ": " + tr.error()};
    if (tr->content_hash() != t.expert_hash)
      return Error{log.path + ": " + t.params.expert_file +
                   " is not the expert recording this session was trained on (its content differs)"};
    run->expert_ = std::make_unique<haptics::ExpertTrack>(std::move(*tr));
    auto m = haptics::TrainingMode::create(t.params, *run->expert_);
    if (!m) return Error{log.path + ": training: " + m.error()};
    run->training_ = std::make_unique<haptics::TrainingMode>(std::move(*m));
    cfg.training = run->training_.get();
  }
  auto eng = haptics::Engine::create(cfg, *run->replay_, *run->volume_, *run->bur_, nullptr);
  if (!eng) return Error{log.path + ": " + eng.error()};
  run->engine_ = std::move(*eng);
  run->setup_ = setup;
  return run;
}

Status Run::make_pipeline(const ar::StationScene& station, const ar::PipelineOptions& options) {
  meshes_ = std::make_unique<ar::ToothMeshes>(*volume_);
  auto p = ar::FramePipeline::create(station, options);
  if (!p) return Error{p.error()};
  pipeline_ = std::move(*p);
  return pipeline_->warm_up(*meshes_);
}

Status Run::record_to(const std::string& dir) {
  auto r = Recorder::open(dir);
  if (!r) return Error{r.error()};
  recorder_ = std::move(*r);
  return {};
}

}  // namespace dentar::session
