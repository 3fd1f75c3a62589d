# Every dependency is a Debian 12 package (see tools/bootstrap.sh). Nothing is
# vendored or downloaded at build time.
find_package(Threads REQUIRED)
find_package(Eigen3 3.4 REQUIRED NO_MODULE)
find_package(PkgConfig REQUIRED)
find_package(nlohmann_json 3.11 REQUIRED)
find_package(CLI11 REQUIRED)
find_package(spdlog REQUIRED)
find_package(ZLIB REQUIRED)
find_package(OpenCV 4.6 REQUIRED COMPONENTS core imgproc calib3d imgcodecs videoio aruco)
# VISPConfig.cmake rewrites global flags (C++ standard, -fopenmp); keep ours.
set(_dentar_saved_cxx_flags "${CMAKE_CXX_FLAGS}")
find_package(VISP 3.5 REQUIRED)
set(CMAKE_CXX_FLAGS "${_dentar_saved_cxx_flags}")
set(CMAKE_CXX_STANDARD 20)
pkg_check_modules(APRILTAG REQUIRED IMPORTED_TARGET apriltag>=3.3)
pkg_check_modules(EGL REQUIRED IMPORTED_TARGET egl)
pkg_check_modules(GLES REQUIRED IMPORTED_TARGET glesv2)
pkg_check_modules(LIBUSB REQUIRED IMPORTED_TARGET libusb-1.0)
pkg_check_modules(CAIRO REQUIRED IMPORTED_TARGET cairo>=1.16)
# Motion JPEG cameras are decoded with TurboJPEG directly (ar/capture, issue 28).
pkg_check_modules(TURBOJPEG REQUIRED IMPORTED_TARGET libturbojpeg>=2.0)

if(DENTAR_BUILD_TESTS)
  find_package(GTest REQUIRED)
endif()
if(DENTAR_BUILD_BENCH)
  find_package(benchmark REQUIRED)
endif()
