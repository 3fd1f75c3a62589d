// The AR compositor: puts the live-cut virtual tooth, the virtual bur and
// their reflection in the real mouth mirror into the camera video, hidden
// wherever real things are in front of them.
//
// One frame (compose()):
//  1. The video frame, as captured (distorted), is the background. The
//     composite is in the camera's distorted image like the video: virtual
//     content is drawn on an undistorted pinhole canvas (projection.h:
//     plan_undistorted_view, the same plan and per-pixel map the Renderer
//     uses) and resampled through the distortion map, on the CPU and only in
//     the region the overlay covers (its bounding box on the canvas).
//  2. Known real geometry goes into the depth buffer only ("phantoms"): the
//     mannequin (head, lips, cheeks, gums, other teeth; the generator's own
//     mesh of station.mannequin), the tracked mirror (face, body, tag paddle)
//     and the handpiece on the stylus.
//  3. Mirror: when the mirror is tracked and its reflecting face (+z of `mir`)
//     faces the camera, the visible part of the face is marked in the
//     stencil buffer and the tooth and bur are drawn reflected about the
//     mirror plane (winding flipped; fragments that the reflection brings in
//     front of the plane, i.e. things behind the mirror, are discarded), with
//     the mirror's reflectance as opacity. The reflected mannequin is a depth
//     phantom there too. The face then hides the tooth behind it (also with
//     phantoms off).
//  4. The tooth at T_cam_tooth = T_cam_man * T_man_tooth and the bur at
//     T_cam_tip = T_cam_man * T_man_dev * T_dev_sty * T_sty_tip, lit, opaque.
//  5. Unknown foreground (hands): ForegroundSegmenter (occlusion.h) on the
//     tooth's region only; the overlay's opacity is multiplied by
//     (1 - foreground), feathered by a Gaussian of feather_px.
//
// Tooth mesh: one GPU buffer set per volume chunk, re-built only for chunks
// whose ChunkMesh::version changed (the mesher's dirty chunks), with coarser
// levels of detail made by vertex clustering on the voxel grid (cluster =
// mean of its vertices; vertices on chunk seams cluster only among
// themselves, so both chunks agree and no cracks open). A level is chosen
// per frame from its measured error in pixels at the tooth's distance
// (lod_max_error_px) and then the triangle budget. Chunks whose box misses the view (or, for the
// reflection, the mirror disc's screen box or the mirror's front side) are
// not drawn. All tooth materials are drawn opaque in their material colours.
// Phantom parts (the mannequin in cells of 1 cm, by the axis their faces turn to) are not
// drawn when their screen box misses the region, when all their faces turn away from the eye
// (cull_facing_away), or in the reflection when they lie wholly behind what it draws in colour
// (phantom_depth_cull).
//
// A second tool (issue 27, the expert's tool of a lesson; CompositeInput::expert): the
// bur and the handpiece at T_cam_exp = T_cam_man * T_man_tooth * T_tooth_exp, drawn after
// everything else, translucent (opacity, tint), in the direct view and, as the student's
// bur, in the mirror's reflection (opacity times the reflectance). By default it is
// overlaid (the seed's mode 5: "overlaid, passes through the tooth"): drawn over the tooth,
// the phantoms and the mannequin, so a hint is never hidden; with depth_tested it is hidden
// like a real instrument (behind the lips, inside the enamel). It writes no tooth coverage;
// its own nearest surface only is blended (a depth pre-pass), so the handpiece does not
// show its far side through itself. With no
// expert (expert.valid false) and tooth_tint (1, 1, 1) the output is bit-identical to a
// compositor without this feature (the OfflineHash tests).
//
// Regions (issue 28: the frame's cost follows the overlay, not the frame): every
// stage after the tracking works inside the overlay's rectangle only: the canvas
// passes are scissored to the bounding box of what is drawn in colour (tooth, bur,
// the mirror's face, the expert's tool; 3 px margin), phantom parts and tooth chunks
// whose screen boxes miss it are not drawn, nor are groups of tooth triangles that all
// turn away from the eye; the readback, resampling, segmentation and blend run on
// that rectangle's image in the output (CompositeResult::region). Outside it the
// composite is the camera's own pixels. The whole-frame path
// (CompositorOptions::region_path = false) runs the same stages over the whole
// frame, as the rival for tests and benchmarks: inside the region it gives the same
// pixels, outside it the same video (compositor_region_gl_test).
//
// Lost tracking: man_valid = false gives the video unchanged (no overlay at
// all: a tooth at a stale pose is worse than none); mirror_valid = false
// gives no reflection and no mirror phantom; stylus_valid = false gives no
// bur and no handpiece phantom.
//
// Two outputs (same passes up to step 4):
//  - compose(): the CPU image (offline driver, tests, the live fallback).
//    The overlay region of the canvas is read back (glReadPixels), resampled
//    with cv::remap, segmented and blended over the BGR video on the CPU.
//  - compose_gl(): the GPU path of the live display. The video is uploaded
//    as an RGBA8 texture (one SIMD colour conversion on the CPU, then a plain
//    copy in the driver); the resampling through the distortion map, the
//    segmentation (the same classifier as ForegroundSegmenter, in a shader;
//    its adapted colour model stays on the GPU: a reduction pass and a 1x1
//    texture) and the blend run in shaders into a caller's RGBA8 texture,
//    inside the overlay's region only (GlFrameTarget). The composite is that
//    region over the video texture: the window blits the two (gl_handoff.h
//    hands both over), so no shader pass runs over the whole frame (on
//    llvmpipe a full-frame shader costs more than the CPU path's whole
//    blend; a blit is its fast path). Nothing is read back;
//    CompositeResult::readback_px and cpu_blend_px say so per frame. No
//    image and no tooth_visible come back (tooth_px = -1); the work is left
//    queued (no glFinish): the caller fences it. The two outputs agree
//    within a grey level or two per pixel (float vs fixed-point arithmetic;
//    tested in compositor_gpu_gl_test).
//
// Thread/context: create() and compose() need the same EGL context current
// on the calling thread (egl_context.h); destroy the Compositor before the
// context. Not thread-safe. The Compositor is move-only (it owns GL objects
// through a unique_ptr).
#pragma once

#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "dentar/ar/meshes.h"
#include "dentar/ar/occlusion.h"
#include "dentar/ar/station_scene.h"
#include "dentar/volume/bur.h"
#include "dentar/volume/result.h"
#include "dentar/volume/surface.h"

namespace dentar::ar {

struct CompositorOptions {
  bool phantoms = true;      // mannequin, mirror, handpiece into depth only
  bool segmentation = true;  // unknown foreground (hands) in the tooth's region
  bool mirror = true;        // reflection of tooth and bur in the tracked mirror
  bool draw_bur = true;      // the virtual bur at the stylus tip
  bool cull_chunks = true;   // skip chunks outside the view / the mirror's view
  // With cull_chunks: also skip the groups of a chunk's triangles whose faces all turn
  // away from the eye (each chunk's triangles are grouped by the axis their faces turn
  // to, each group with its normal cone; back-face culling would drop every one of those
  // triangles after the vertex work). Same pixels either way (tested).
  bool cull_facing_away = true;
  // Issue 28 session 23: in the mirror's reflection the mannequin is a depth-only phantom: its
  // parts wholly farther than everything the reflection draws in colour (the tooth's and the
  // bur's boxes) hide nothing and are not drawn. Same pixels either way (tested). Off when
  // the expert's tool is depth-tested (it is drawn there too).
  bool phantom_depth_cull = true;
  // Issue 28 session 23: with cull_facing_away, the mannequin's parts whose faces all turn
  // away from the eye are not drawn either (as the tooth's groups; the same pixels).
  bool phantom_facing_cull = true;
  // The mannequin's parts for culling: cubes of this edge (m; by triangle centroid, and by
  // facing). Fixed at create().
  double phantom_cell_m = 0.01;
  // Issue 28 session 23: the canvas passes switch which attachments they write by write
  // masks (glColorMaski), not by glDrawBuffers (a framebuffer change: llvmpipe flushes its
  // queued work at each). Same pixels (tested). false = glDrawBuffers (before session 23).
  bool attachment_masks = true;
  // Most tooth triangles to draw per view (direct and reflected each); the
  // level of detail is coarsened until the tooth fits. 0 = no limit.
  std::size_t triangle_budget = 0;
  // Coarsest level of detail allowed by screen error: a level is usable when
  // its geometric error (largest move of a vertex along its normal, measured
  // when the level is built) is at most this many pixels at the tooth's
  // distance. 0 = always the full mesh (unless the budget forces a coarser one).
  double lod_max_error_px = 1.0;
  // Issue 28: lod_max_error_px is for a frame this wide (px); a wider frame of the
  // same field of view allows width / this as many px (the same error in angle,
  // so the tooth's vertex work does not grow with the camera's resolution; 1 px
  // at 640 px wide is 3 px at 1920). 0 = px of the frame itself at every width.
  // Measured (docs/BENCHMARKS.md, "Issue 28 session 16"): the drawn outline's
  // distance to the full mesh's stays within its 640x480 value at 1920x1080.
  double lod_reference_width_px = 640;
  // Issue 28 session 23: the reflected tooth gets its own level of detail by the same error
  // budget at its virtual image's distance (camera to mirror to tooth: farther than the
  // tooth, so coarser, never finer than the direct view's). false (default) = the direct
  // view's level in the mirror too. Off by default: on the bench's footage it never chose
  // another level (docs/BENCHMARKS.md, issue 28 session 23).
  bool reflection_lod = false;
  // Issue 28 session 23: triangles per pixel. After the error budget above, the level is
  // coarsened while its mean triangle would cover fewer than this many px on screen (the
  // level's total area A over its n triangles: ~A / (2 n) projected, a closed surface's mean)
  // and the next level's error is at most lod_triangle_max_error_px px of this frame. Every
  // level is made from the current volume's chunk meshes (re-made when a chunk changes), so
  // a cut shows at every level. 0 = off (the error budget alone, before session 23).
  double lod_min_triangle_px = 0;
  double lod_triangle_max_error_px = 4;
  // Cluster cell of the coarser levels (1, 2, ...), voxels, increasing, each
  // dividing the chunk size 16.
  std::vector<int> lod_cell_voxels = {2, 4, 8};
  // Soft edge of the foreground mask: Gaussian sigma, px (0 = hard edge).
  double feather_px = 0.7;
  // Opacity of the reflection (a glass mouth mirror reflects ~85-90 %).
  double mirror_reflectance = 0.85;
  // Virtual bur (shape as cut with) and the real handpiece's shape (phantom).
  volume::BurParams bur = volume::BurParams::capsule(0.5, 3.0);
  HandpieceParams handpiece;
  SegmenterOptions segmenter;
  double near_m = 0.01, far_m = 5.0;  // clip planes, camera z
  // Issue 28: the region path (default) does the compositor's work only where the overlay
  // is (see "Regions" above; set at create() and by set_options()); false = the whole-frame path, kept as the rival that tests and
  // benchmarks compare against: the same composite, every stage run over the whole frame.
  bool region_path = true;

  std::string validate() const;  // empty, or names the field
};

// The expert's tool as a second, translucent handpiece (see above). `exp` is the expert's
// bur tip frame (+z = bur axis out of the handpiece, as `tip`), given in the tooth frame.
struct ExpertTool {
  bool valid = false;  // false: not drawn
  Eigen::Isometry3d T_tooth_exp = Eigen::Isometry3d::Identity();
  double opacity = 0.45;  // (0, 1]: the ghost's coverage where it is seen
  // Multiplies the instrument colours (sRGB, each 0..2): a cool blue by default, so the
  // expert's tool is never mistaken for the student's grey one.
  Eigen::Vector3f tint{0.55f, 0.80f, 1.30f};
  // false: overlaid over everything (a hint is never hidden); true: hidden by the phantoms
  // (mannequin, mirror, the student's handpiece) and the tooth, as a real instrument.
  bool depth_tested = false;
  std::string validate() const;  // empty, or names the field
};

struct CompositeInput {
  // Camera size, as captured (distorted): CV_8UC3 BGR, or CV_8UC2 YUYV 4:2:2 as the
  // camera sent it (issue 28; even width). YUYV: compose() converts it once into
  // out.image (the copy it makes of any frame; OpenCV's COLOR_YUV2BGR_YUYV), and
  // compose_gl uploads it as it came (2 bytes a pixel) and converts in a shader
  // with the same integer arithmetic.
  const cv::Mat* video_bgr = nullptr;
  bool man_valid = false;              // false: tracking lost, no overlay at all
  Eigen::Isometry3d T_cam_man = Eigen::Isometry3d::Identity();
  bool mirror_valid = false;
  Eigen::Isometry3d T_cam_mtag = Eigen::Isometry3d::Identity();
  bool stylus_valid = false;
  Eigen::Isometry3d T_dev_sty = Eigen::Isometry3d::Identity();  // haptic snapshot
  // Issue 27: the expert's tool (not drawn unless expert.valid), and a tint multiplying the
  // tooth's material colours in both views (sRGB, each 0..2; mode 5 changes it while the
  // recording drills). (1, 1, 1) = the material colours.
  ExpertTool expert;
  Eigen::Vector3f tooth_tint = Eigen::Vector3f::Ones();
  // Issue 28 session 20: compose() with a YUYV video keeps the camera's frame outside the
  // overlay. out.image = the camera's YUYV frame itself (its buffer shared, not copied:
  // never write into it), out.patch = the BGR composite inside out.patch_rect (the overlay's
  // region widened to even columns, so YUYV's pairs convert whole); nothing outside it is
  // converted. composite_bgr() gives the whole BGR frame (the same pixels as keep_yuyv =
  // false); the live window converts the rest in its upload (HudWindow::set_video). Ignored
  // for BGR video and by compose_gl.
  bool keep_yuyv = false;
};

// Wall-clock time of each stage of compose(), ms.
struct CompositeTimings {
  double sync_ms = 0;      // re-uploading changed chunks (and their LODs)
  double segment_ms = 0;   // foreground segmentation + feathering
  double render_ms = 0;    // GL passes, to completion
  double readback_ms = 0;  // glReadPixels of the overlay region
  double blend_ms = 0;     // distortion resampling + blend over the video
  double upload_ms = 0;    // compose_gl: the video frame into its texture
  double total_ms = 0;     // compose_gl: CPU time to queue the work, not its completion
};

// compose_gl's output textures (in the current context's share group).
struct GlFrameTarget {
  // RGBA8, camera size: receives the frame (RGB, row 0 = image top).
  unsigned video_texture = 0;
  // RGBA8, camera size: receives the composite (RGB, alpha 1) inside
  // CompositeResult::region (row 0 = image top); outside it, left as it was:
  // there the composite is the video.
  unsigned overlay_texture = 0;
};

struct CompositeResult {
  cv::Mat image;          // CV_8UC3 BGR composite, camera size (CV_8UC2: keep_yuyv, see patch)
  // CompositeInput::keep_yuyv with a YUYV video: the BGR composite inside patch_rect (which
  // holds `region`, widened to even columns); empty when nothing was drawn. Outside it the
  // composite is `image`'s YUYV converted (COLOR_YUV2BGR_YUYV).
  cv::Mat patch;
  cv::Rect patch_rect;
  cv::Mat tooth_visible;  // CV_8UC1 0..255: the directly seen virtual tooth after occlusion (soft)
  bool overlay_drawn = false;  // man_valid and something was drawn
  bool mirror_drawn = false;   // the reflection pass ran
  int tooth_px = 0;            // pixels with tooth_visible > 127 (-1: compose_gl, not measured)
  bool expert_drawn = false;   // the expert's tool was drawn (in view or in the mirror)
  std::size_t triangles_drawn = 0;  // tooth triangles, direct + reflected
  int chunks_culled = 0;            // direct + reflected
  int lod_level = 0;                // 0 = full mesh
  cv::Rect region;                  // output pixels touched by the overlay (may be empty)
  // What crossed between GPU and CPU for this frame: pixels read back with
  // glReadPixels (each attachment counts) and pixels blended on the CPU.
  // compose_gl: both 0, always.
  std::int64_t readback_px = 0;
  std::int64_t cpu_blend_px = 0;
  bool gpu_output = false;          // compose_gl: the composite is in the target textures
  CompositeTimings timing;
};

// The whole BGR composite of `r` (camera size) into `bgr`: `r.image` itself when it is BGR;
// a keep_yuyv result's YUYV converted with its patch over it (the same pixels as compose()
// with keep_yuyv = false). Empty `r.image`: `bgr` released.
void composite_bgr(const CompositeResult& r, cv::Mat& bgr);

class Compositor {
 public:
  // Needs a current EGL context. Camera: station.calibration.camera. Errors
  // name the option or station field, or the GL failure.
  static Result<Compositor> create(const StationScene& station,
                                   const CompositorOptions& options = {});
  Compositor(Compositor&&) noexcept;
  Compositor& operator=(Compositor&&) noexcept;
  ~Compositor();

  // Composites one frame. Syncs the tooth from `surface` first (only chunks
  // whose mesh version changed). Errors: no/empty video frame, wrong type,
  // frame size != camera size (a station file for another camera), GL
  // errors. On error `out` is left unchanged (but for a GL error after the draw: then
  // its frame-size buffers, which compose() reuses when `out` alone holds them, may be
  // taken or overwritten).
  Status compose(const volume::Surface& surface, const CompositeInput& in, CompositeResult& out);
  // The GPU path (see above): composites into `target` (GlFrameTarget).
  // Same errors as compose(), plus gpu_path_error()'s and unusable targets.
  // `out.image` and `out.tooth_visible` come back empty; out.region says
  // where the overlay texture holds the composite.
  Status compose_gl(const volume::Surface& surface, const CompositeInput& in,
                    const GlFrameTarget& target, CompositeResult& out);
  // Empty when compose_gl() can run in the current context, else why not
  // (e.g. no EXT_color_buffer_float for the segmenter's float targets).
  // Builds the GPU path's shaders and textures on the first call.
  std::string gpu_path_error();
  // Test aid (reads the 1x1 model texture back; never called on the live
  // path): the GPU path's adapted foreground model, (g/r, b/r).
  Eigen::Vector2d gpu_model_chroma_for_test();

  const CompositorOptions& options() const;
  // Changes options between frames (validated; geometry options such as the
  // bur, handpiece and lod_cell_voxels are fixed at create() and ignored
  // here). Resets the segmenter's adapted colour model.
  Status set_options(const CompositorOptions& options);
  // Tooth triangles per level of detail (level 0 = full), after the last
  // sync, and each level's geometric error (m, see lod_max_error_px).
  std::vector<std::size_t> lod_triangle_counts() const;
  std::vector<double> lod_errors_m() const;
  const ForegroundSegmenter& segmenter() const;

  struct Impl;

 private:
  Compositor() = default;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dentar::ar
