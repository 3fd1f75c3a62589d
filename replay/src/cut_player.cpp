// See cut_player.h. The set-up follows haptics::replay_session (the same header, bur and
// training mode), but the engine is kept between seeks so the cut advances step by step.
#include "dentar/replay/cut_player.h"

#include <cstdio>

namespace dentar::replay {

Result<std::unique_ptr<CutPlayer>> CutPlayer::create(const Recording& rec) {
  std::unique_ptr<CutPlayer> p(new CutPlayer);
  p->rec_ = &rec;
  const auto& setup = rec.setup;
  if (rec.start->content_hash() != setup.volume_hash_start) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "the rebuilt tooth (hash %016llx) is not the session's starting tooth (%016llx)",
                  static_cast<unsigned long long>(rec.start->content_hash()),
                  static_cast<unsigned long long>(setup.volume_hash_start));
    return Error{rec.log_path + ": " + buf};
  }
  auto bur = volume::sample_bur(setup.bur, setup.bur_samples);
  if (!bur) return Error{rec.log_path + ": header field 'bur': " + bur.error()};
  p->bur_ = std::make_unique<volume::BurSamples>(std::move(bur).value());
  p->engine_cfg_ = setup.engine;
  if (setup.training) {
    // A session trained in a mode: its expert recording cut too (replay_session does the same).
    const haptics::TrainingSetup& t = *setup.training;
    auto expert = haptics::read_session_log(t.params.expert_file);
    if (!expert) return Error{rec.log_path + ": the session was trained on " + t.params.expert_file + ": " + expert.error()};
    auto tr = haptics::ExpertTrack::from_records(expert->records, t.expert_T_tooth_dev, t.expert_T_sty_tip,
                                                 t.params.expert_file);
    if (!tr) return Error{rec.log_path + ": " + tr.error()};
    if (tr->content_hash() != t.expert_hash)
      return Error{rec.log_path + ": " + t.params.expert_file +
                   " is not the expert recording this session was trained on (its content differs)"};
    p->expert_.emplace(std::move(tr).value());
    auto m = haptics::TrainingMode::create(t.params, *p->expert_);
    if (!m) return Error{rec.log_path + ": " + m.error()};
    p->mode_.emplace(std::move(m).value());
  }
  p->volume_ = std::make_unique<volume::VoxelVolume>(rec.start->clone());
  p->surface_ = std::make_unique<volume::Surface>(*p->volume_);
  p->surface_->extract_all();
  if (Status st = p->restart(); !st) return Error{st.error()};
  return p;
}

CutPlayer::~CutPlayer() = default;

Status CutPlayer::restart() {
  engine_.reset();
  device_.reset();
  if (done_ > 0) {
    *volume_ = rec_->start->clone();
    surface_->extract_all();
  }
  if (mode_) {
    auto m = haptics::TrainingMode::create(rec_->setup.training->params, *expert_);
    if (!m) return Error{rec_->log_path + ": " + m.error()};
    mode_.emplace(std::move(m).value());
    engine_cfg_.training = &*mode_;
  }
  device_ = std::make_unique<haptics::ReplayDevice>(rec_->log->records, rec_->setup.limits);
  auto engine = haptics::Engine::create(engine_cfg_, *device_, *volume_, *bur_, nullptr);
  if (!engine) return Error{rec_->log_path + ": replay: " + engine.error()};
  engine_ = std::move(engine).value();
  done_ = 0;
  time_s_ = 0;
  return {};
}

Result<std::uint64_t> CutPlayer::seek(double t_s) {
  t_s = std::clamp(t_s, 0.0, rec_->duration_s);
  // Records up to and including the one at t.
  const std::size_t target = rec_->record_at(t_s) + 1;
  if (target < done_) {
    if (Status st = restart(); !st) return Error{st.error()};
  }
  std::uint64_t ran = 0;
  if (target > done_) {
    ran = engine_->run_steps(target - done_);
    done_ += static_cast<std::size_t>(ran);
    surface_->update();
  }
  time_s_ = t_s;
  return ran;
}

Eigen::Isometry3d CutPlayer::T_tooth_tip() const {
  const auto& recs = rec_->log->records;
  const haptics::StepRecord& r = recs[done_ > 0 ? done_ - 1 : 0];
  Eigen::Isometry3d T_dev_sty = Eigen::Isometry3d::Identity();
  T_dev_sty.linear() = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(r.rotation);
  T_dev_sty.translation() = Eigen::Vector3d(r.position_m[0], r.position_m[1], r.position_m[2]);
  return rec_->setup.engine.T_tooth_dev * T_dev_sty * rec_->setup.engine.T_sty_tip;
}

bool CutPlayer::pedal() const {
  const auto& recs = rec_->log->records;
  return recs[done_ > 0 ? done_ - 1 : 0].pedal != 0;
}

bool CutPlayer::contact() const {
  const auto& recs = rec_->log->records;
  return (recs[done_ > 0 ? done_ - 1 : 0].flags & haptics::kFlagContact) != 0;
}

}  // namespace dentar::replay
