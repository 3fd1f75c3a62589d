// session::Run: the one object that owns a run's parts, for every driver
// (`dentar offline`; the live drivers take its recorder and its session-log
// set-up):
//   - the tooth volume and the bur's samples,
//   - the haptic device and the 1 kHz engine over them,
//   - the tooth meshes and the shared per-frame pipeline (ar::FramePipeline),
//   - the recorder of a `dentar live --record` folder.
// Built from a station (an uncut tooth of the station's voxel size, no
// engine) or from a recording (a session log: its header rebuilds the tooth,
// checked against volume_hash_start, the bur and the engine; its records drive
// a replay device).
//
// Members refer to each other (the engine to the device, volume and bur; the
// meshes to the volume): a Run is made on the heap and never moves.
//
// Thread/context: built on one thread; pipeline() and meshes() are then used
// on the frame thread (make_pipeline needs that thread's current GL context),
// the engine runs on its own thread or is stepped by the caller (replay).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "dentar/ar/frame_pipeline.h"
#include "dentar/ar/station_scene.h"
#include "dentar/haptics/engine.h"
#include "dentar/haptics/replay.h"
#include "dentar/haptics/replay_device.h"
#include "dentar/haptics/session_log.h"
#include "dentar/session/lesson_clock.h"
#include "dentar/session/recorder.h"
#include "dentar/volume/bur.h"
#include "dentar/volume/result.h"
#include "dentar/volume/voxel_volume.h"

namespace dentar::session {

// A session log read for a run: its header's set-up, its records, and the
// tooth the header describes, rebuilt and checked (volume_hash_start).
struct SessionLogSetup {
  std::string path;
  haptics::SessionSetup setup;
  std::vector<haptics::StepRecord> records;
  std::string tooth_json;  // the header's "tooth"
  std::string warning;     // the reader's (a log cut short), or empty
};
// Reads `path` and parses its header. Errors name the file and the field.
Result<SessionLogSetup> read_session_setup(const std::string& path);
// The tooth a header's "tooth" describes (training::make_start_tooth: the
// procedural molar or incisor; a molar logged before session 18 gets its old pulp
// when `start_hash`, the header's volume_hash_start, says so). `log_path` names the
// file in messages.
Result<volume::VoxelVolume> tooth_from_header(const std::string& tooth_json, std::uint64_t start_hash,
                                              const std::string& log_path);

class Run {
 public:
  // An uncut procedural molar of the station's voxel size; no engine, no bur.
  static Result<std::unique_ptr<Run>> from_station(const ar::StationScene& station);
  // A replay of a session log: the log's tooth, bur and engine (with the training
  // mode its header recorded, rebuilt from the expert's recording), driven by its
  // records through a ReplayDevice; the engine never asks for real time.
  // Warnings (another station registration than the log's) go to warnings().
  // A trained session's expert recording is checked against the header's hash; the engine's
  // snapshot then carries the expert's tool (drawn by the frame pipeline as a second handpiece).
  static Result<std::unique_ptr<Run>> from_session_log(SessionLogSetup log, const ar::StationScene& station,
                                                       const std::string& station_name);

  Run(const Run&) = delete;
  Run& operator=(const Run&) = delete;
  ~Run();

  // A live run: the tooth drilled and the bur; the engine comes with make_engine.
  static std::unique_ptr<Run> from_tooth(volume::VoxelVolume tooth, volume::BurSamples bur);
  // A lesson (before make_engine): its training mode is the engine's.
  void set_lesson(std::unique_ptr<LessonClock> lesson) { lesson_ = std::move(lesson); }
  LessonClock* lesson() { return lesson_.get(); }
  // The engine of a live run over `device` (not owned: it must outlive the Run), whose
  // session log (header: the engine's, with `tooth_json`) is written to `log_path` ("" = no
  // log). Errors: "engine: ..." (the configuration), or the log file's.
  Status make_engine(const haptics::EngineConfig& cfg, haptics::HapticDevice& device, const std::string& tooth_json,
                     const std::string& log_path);
  // Closes the session log (after the engine stopped); ok when there is none.
  Status close_session_log();

  // The tooth meshes and the pipeline (on the frame thread, with its GL
  // context current): create_pipeline, then warm_up (into `target` when the
  // composite stays on the GPU).
  Status make_pipeline(const ar::StationScene& station, const ar::PipelineOptions& options);
  Status create_pipeline(const ar::StationScene& station, const ar::PipelineOptions& options);
  Status warm_up(const ar::GlFrameTarget& target = {});
  // The pipeline and the meshes released (on the frame thread, before its GL context goes).
  void drop_pipeline();
  // Opens the recorder of a `dentar live --record` folder.
  Status record_to(const std::string& dir, bool stereo = false);  // stereo: Recorder::open's

  volume::VoxelVolume& volume() { return *volume_; }
  bool has_engine() const { return engine_ != nullptr; }
  haptics::Engine* engine() { return engine_.get(); }
  haptics::ReplayDevice* replay_device() { return replay_.get(); }
  const std::optional<haptics::SessionSetup>& setup() const { return setup_; }
  double rate_hz() const { return setup_ ? setup_->engine.rate_hz : 1000.0; }
  std::size_t session_steps() const { return session_steps_; }
  ar::ToothMeshes& meshes() { return *meshes_; }
  ar::FramePipeline& pipeline() { return *pipeline_; }
  Recorder* recorder() { return recorder_.get(); }
  const std::vector<std::string>& warnings() const { return warnings_; }

 private:
  Run() = default;
  std::optional<volume::VoxelVolume> volume_;
  std::optional<volume::BurSamples> bur_;
  std::optional<haptics::SessionSetup> setup_;
  std::unique_ptr<haptics::ReplayDevice> replay_;
  std::unique_ptr<LessonClock> lesson_;  // before the engine that steps its mode
  std::unique_ptr<haptics::SessionLogWriter> log_;
  std::unique_ptr<haptics::Engine> engine_;
  std::size_t session_steps_ = 0;
  std::unique_ptr<ar::ToothMeshes> meshes_;
  std::unique_ptr<ar::FramePipeline> pipeline_;
  std::unique_ptr<Recorder> recorder_;
  std::vector<std::string> warnings_;
};

}  // namespace dentar::session
