// Frame sources for tracking: a video file, a folder of image files, or a
// live camera (V4L2 through cv::VideoCapture), behind one interface that
// hands out BGR frames with a monotonic capture time and dropped-frame
// accounting.
//
// Spec strings (FrameSource::open):
//   camera:N            V4L2 camera index N (cv::CAP_V4L2)
//   /dev/videoN         V4L2 device path
//   live:PATH           a video file standing in for a live camera: the
//                       camera reader itself, paced in real time at the
//                       file's fps; frames the consumer was too slow for are
//                       skipped and counted as dropped, like a camera's
//   DIR                 a folder: its image files (png, jpg, jpeg, bmp, pgm,
//                       ppm, tif, tiff) in name order
//   FILE                a video file (FFmpeg)
//
// Timestamps (Frame::time_s, seconds, monotonic, starting near 0):
//   video file: the container's timestamp (CAP_PROP_POS_MSEC), or index/fps
//     when the container has none;
//   folder: index / folder_fps;
//   camera / live: std::chrono::steady_clock since open, taken when the frame
//     is grabbed.
// Motion JPEG cameras and stand-ins: the compressed frame is read as it came
// (V4L2 without conversion, FFmpeg in raw packet mode), kept in
// Frame::encoded and decoded with TurboJPEG (MjpegDecoder, mjpeg_decoder.h;
// session 18, before: cv::imdecode); when the driver does not hand out JPEG
// bytes, the source falls back to the backend's decoding. A JPEG frame that
// does not decode (corrupt, cut short on the bus) is skipped and counted as
// dropped (Frame::dropped_before, dropped_total) and in corrupt_total(), its
// reason in last_corrupt(); more than 10 in a row end the stream with an error
// naming the last reason.
// The camera's own format (issue 28, FrameSourceOptions::pixel_format "native"):
// a camera (or stand-in) that delivers YUYV 4:2:2 hands its frames on as they
// came, Frame::image CV_8UC2 (Y0 U Y1 V, BT.601, luma 16..235), with no colour
// conversion on the capture thread; who needs BGR converts what it uses
// (frame_bgr below, the compositor, the window's upload). A V4L2 camera is read
// with the backend's conversion off; a stand-in is an AVI of raw YUY2 frames
// (write_yuyv_avi), read as FFmpeg's raw packets. Motion JPEG with "native" is
// decoded to the JPEG's own Y'CbCr planes and handed on as YUYV (CV_8UC2, the
// same limited-range layout: mjpeg_decoder.h), so the tracker reads its luma and
// the compositor converts only what it draws, as for a YUYV camera; with "bgr"
// it is decoded straight to BGR. Its bytes are kept in Frame::encoded either way.
// Any other format goes through the backend's conversion to BGR.
// FrameSourceOptions::fourcc asks a camera for a format: the driver's answer is
// checked (negotiate_format), and a camera that cannot give it is an error naming
// what it gives; a stand-in is held to the same rule (its file's format is what
// its "driver" offers).
// Dropped frames: camera/live: a gap between consecutive frames longer than
// 1.5 frame periods counts round(gap / period) - 1 frames; files: a frame
// that fails to decode is counted (dropped_before of the next good frame)
// and reported, never silently skipped; more than 10 in a row ends the
// stream with an error (a corrupt file).
//
// Errors (Result): missing path, unreadable/corrupt/empty video, an image of
// another size or an unreadable image inside a folder, a camera that cannot
// be opened. Messages name the source and say what to do.
// Thread: one reader thread per source.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "dentar/volume/result.h"

namespace cv {
class VideoCapture;
}

namespace dentar::ar {

struct FrameSourceOptions {
  // Camera requests (0 = leave the driver's default). The driver may choose
  // another mode: width()/height()/fps() report what it delivers.
  int width = 0, height = 0;
  double fps = 0;
  double folder_fps = 30;  // timestamps of image folders, Hz
  // Live sources: "bgr" (default) hands on BGR frames whatever the camera sends;
  // "native" keeps the camera's own YUYV (Frame::image CV_8UC2, see above) and
  // hands on Motion JPEG as YUYV from the JPEG's planes. Image folders: "native"
  // decodes their .jpg/.jpeg files as a live source does (read_frame_image), so a
  // live recording of a Motion JPEG camera replays from the same pixels.
  std::string pixel_format = "bgr";
  // Motion JPEG: libjpeg-turbo's fast integer IDCT (TJFLAG_FASTDCT) instead of the
  // accurate one (docs/BENCHMARKS.md, session 18: its cost in pixel error).
  bool jpeg_fast_dct = false;
  // Motion JPEG live sources (session 20): hand on each frame after the first
  // undecoded: Frame::image empty, Frame::encoded the camera's bytes, checked
  // only for what needs no pixels (MjpegDecoder::check: markers, header, size);
  // whoever takes the frame decodes it (CaptureThread decodes the frames its
  // consumer takes, so a frame replaced unseen costs no decode). A frame that then fails to decode is the taker's to drop and count.
  // Off: every frame is decoded on the reader's thread (sessions 18-19).
  bool defer_jpeg_decode = false;
  // Live sources: the format asked of the camera, "" (the driver's default),
  // "YUYV" or "MJPG"; a camera that does not deliver it is refused (the error
  // names what it delivers).
  std::string fourcc;
  std::string validate() const;  // empty when valid, else names the field
};

struct Frame {
  // CV_8UC3 BGR (gray files are converted); with pixel_format "native" and a
  // YUYV camera, CV_8UC2 YUYV as the camera sent it (frame_bgr converts).
  cv::Mat image;
  // The frame's number. Video files and folders: 0, 1, ... in delivery order (an undecodable
  // frame is not counted). Camera and live: the frame's number in the stream since the source
  // was opened, the frames it dropped counted (dropped_before): a live: stand-in's frame in its
  // file (time_s = index / fps), a camera's by its gaps; a reopened source (a looped stand-in, a
  // camera back) counts from 0 again. Recordings keep it as frames.csv source_index.
  std::int64_t index = 0;
  double time_s = 0;       // capture time, s (see above)
  int dropped_before = 0;  // frames lost between the previous frame and this one
  // std::chrono::steady_clock time of the capture, s since that clock's
  // epoch (live sources: when the frame was grabbed, or was due for paced
  // footage; files and folders: when it was decoded). Latency starts here.
  double steady_s = 0;
  // The camera's own Motion JPEG bytes of this frame (1xN CV_8UC1, owned),
  // when the source delivers MJPG (a UVC webcam at 720p, an MJPG stand-in);
  // empty otherwise. `image` is exactly these bytes decoded (MjpegDecoder: BGR,
  // or YUYV with pixel_format "native"), so a recording that stores them (not a
  // re-encoding) replays bit for bit when decoded the same way (read_frame_image).
  cv::Mat encoded;
};

// One image file as a frame: BGR (cv::imread), except a .jpg/.jpeg file with
// pixel_format "native", which is decoded as a live Motion JPEG source decodes
// (MjpegDecoder, YUYV when the JPEG allows it). Error names the file and why.
Result<cv::Mat> read_frame_image(const std::string& path, const std::string& pixel_format = "bgr");

// A Motion JPEG frame handed on undecoded (FrameSourceOptions::defer_jpeg_decode):
// bytes in Frame::encoded, no image yet.
inline bool frame_undecoded(const Frame& f) { return f.image.empty() && !f.encoded.empty(); }

// steady_clock now, s since its epoch (the clock of Frame::steady_s).
double steady_now_s();

// A frame's image as BGR: the image itself (a header, no copy) when it is BGR,
// else converted once (YUYV: OpenCV's COLOR_YUV2BGR_YUYV, BT.601 limited range;
// grey: replicated). Empty for an empty image.
cv::Mat frame_bgr(const cv::Mat& image);

// What a live source carries for a camera format, decided from what was asked
// and what the driver (or the stand-in's file) delivers.
struct FormatChoice {
  bool yuyv = false;  // hand on the camera's own YUYV bytes (CV_8UC2)
  bool jpeg = false;  // read the Motion JPEG bytes and decode them (Frame::encoded)
};
// requested: FrameSourceOptions::fourcc ("" none); delivered: the driver's FOURCC
// (0 unknown); pixel_format: FrameSourceOptions::pixel_format. Error when a format
// was asked and another is delivered; its message names both and what to do.
Result<FormatChoice> negotiate_format(const std::string& requested, int delivered, const std::string& pixel_format,
                                      const std::string& what);
// "YUYV", "MJPG", ... ("none" for 0, hex for unprintable codes).
std::string fourcc_name(int fourcc);

// A stand-in for a YUYV camera: an AVI of uncompressed YUY2 frames (every frame
// CV_8UC2, one size, even width), which `live:PATH` reads as the camera would
// deliver them. Error names the file when it cannot be written.
Status write_yuyv_avi(const std::string& path, const std::vector<cv::Mat>& yuyv_frames, double fps);
// The same, streamed: `next` fills the next frame and returns false after the last
// (a long 1080p stand-in never sits in memory whole).
Status write_yuyv_avi(const std::string& path, const std::function<bool(cv::Mat&)>& next, double fps);
// A stand-in for a Motion JPEG camera: an AVI whose frames are exactly these bytes
// (normally JPEGs of width x height; corrupt or truncated ones are written as given,
// which is what the tests of a camera's damaged frames need). `live:PATH` reads them
// raw, as a UVC camera's. Error names the file when it cannot be written.
Status write_mjpeg_avi(const std::string& path, const std::vector<std::vector<std::uint8_t>>& jpegs, int width,
                       int height, double fps);
// The same, streamed: `next` fills the next frame's bytes and returns false after the last.
Status write_mjpeg_avi(const std::string& path, const std::function<bool(std::vector<std::uint8_t>&)>& next, int width,
                       int height, double fps);

class FrameSource {
 public:
  static Result<std::unique_ptr<FrameSource>> open(const std::string& spec,
                                                   const FrameSourceOptions& options = {});
  // The live reader over any opened capture (a camera, or a video file
  // standing in for one). `pace`: deliver frames in real time at `fps`
  // (needed when the capture is a file; a camera paces itself).
  static Result<std::unique_ptr<FrameSource>> open_live(std::unique_ptr<cv::VideoCapture> capture,
                                                        const std::string& description,
                                                        double fps, bool pace,
                                                        const FrameSourceOptions& options = {});
  virtual ~FrameSource();
  // Next frame into `out`; false at the end of a file (never for a live
  // camera unless it stops delivering). Errors name the source and frame.
  virtual Result<bool> read(Frame& out) = 0;
  virtual int width() const = 0;
  virtual int height() const = 0;
  virtual double fps() const = 0;                 // nominal, Hz
  virtual std::int64_t frame_count() const = 0;   // -1 unknown (camera)
  virtual std::int64_t dropped_total() const = 0;
  // Motion JPEG frames refused by the decoder (counted in dropped_total too), and
  // the last one's reason ("" none). 0 / "" for sources without JPEG frames.
  virtual std::int64_t corrupt_total() const { return 0; }
  virtual std::string last_corrupt() const { return {}; }
  virtual std::string description() const = 0;  // "video file x.mkv (640x480, 30 fps)"
};

}  // namespace dentar::ar
