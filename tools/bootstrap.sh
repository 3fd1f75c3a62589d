#!/usr/bin/env bash
# One-command set-up for a fresh Debian 12 machine: installs the missing
# Debian packages, configures and builds DentAR (Release), then runs a job.
#
#   tools/bootstrap.sh demo    # build, then run the trainer's main job (dentar offline on built-in footage)
#   tools/bootstrap.sh test    # build, then run the whole test suite (what CI runs)
#   tools/bootstrap.sh bench   # also installs VTK (comparison only), runs the benchmarks
#
# Environment: BUILD_DIR (default build), JOBS (default: number of cores).
set -euo pipefail

job="${1:-demo}"
case "$job" in demo|test|bench) ;; *)
  echo "usage: tools/bootstrap.sh demo|test|bench (got '$job')" >&2; exit 2 ;;
esac

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${BUILD_DIR:-$root/build}"
jobs="${JOBS:-$(nproc)}"

# Debian 12 packages. Runtime EGL needs Mesa (libegl-mesa0 + the llvmpipe
# driver in libgl1-mesa-dri) for headless rendering.
packages=(
  build-essential cmake ninja-build pkg-config
  libeigen3-dev libopencv-dev libopencv-contrib-dev libapriltag-dev libvisp-dev
  libegl-dev libgles-dev libegl-mesa0 libgl1-mesa-dri libusb-1.0-0-dev
  # Motion JPEG cameras: decoded with TurboJPEG (libjpeg-turbo 2.1) directly.
  libturbojpeg0-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libcli11-dev nlohmann-json3-dev libspdlog-dev libfmt-dev zlib1g-dev libsqlite3-dev
  # Real photographs for tests (provenance in tests/README-data.md): OpenCV's
  # chessboard samples (opencv-doc) and ViSP's AprilTag images (visp-images-data).
  opencv-doc visp-images-data
  # The printable station kit (dentar tags): cairo; its tests render the PDF and SVG back
  # to pixels with poppler (pdftoppm) and librsvg (rsvg-convert).
  libcairo2-dev poppler-utils librsvg2-bin
  # The live trainer (dentar live): window and HUD (GLFW 3.3, Dear ImGui 1.86,
  # desktop GL), and Xvfb + xauth + xdotool for its windowed tests.
  libglfw3-dev libimgui-dev libgl-dev xvfb xauth xdotool
  # The session store and the instructor's page: libpq + OpenSSL (PBKDF2, SHA-256),
  # cpp-httplib (built with OpenSSL: HTTPS), PostgreSQL 15 server binaries (initdb,
  # pg_ctl: the store tests make a throwaway cluster) and Chromium (headless page tests).
  libpq-dev libssl-dev libcpp-httplib-dev libbrotli-dev postgresql-15 chromium
  # The drill's sound (sound/): OpenAL Soft (its loopback device renders without a
  # sound card) and libsndfile (WAV renders, optional user samples); FFmpeg's libraries mux
  # the sound track into the composite video (dentar offline --audio-mux).
  libopenal-dev libsndfile1-dev libavformat-dev libavcodec-dev libavutil-dev
)
# bench: VTK for the surface comparison; ffmpeg, stress and rt-tests (cyclictest) for the live benchmarks.
if [[ "$job" == bench ]]; then packages+=(libvtk9-dev ffmpeg stress rt-tests); fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if ((${#missing[@]})); then
  echo "== installing ${#missing[@]} Debian packages: ${missing[*]}"
  sudo_cmd=()
  if [[ $(id -u) -ne 0 ]]; then sudo_cmd=(sudo); fi
  export DEBIAN_FRONTEND=noninteractive
  "${sudo_cmd[@]}" apt-get update -qq
  "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

echo "== configuring and building in $build"
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build "$build" -j "$jobs"

cd "$root"
case "$job" in
  demo)
    "$build/dentar" offline --out "$root/out/offline"
    ;;
  test)
    # Hardware tests (label hw) need a device and are excluded, and so are the
    # long runs (label long: ctest -L long). GL tests must
    # really render here (Mesa llvmpipe is installed above), not skip.
    DENTAR_REQUIRE_GL=1 ctest --test-dir "$build" --output-on-failure -j "$jobs" -LE "hw|long"
    ;;
  bench)
    for b in "$build"/volume/volume_*_bench; do
      echo "== $b"
      "$b" --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
    done
    ;;
esac
