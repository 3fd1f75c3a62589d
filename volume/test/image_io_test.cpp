// Loaders and writers of the three volume formats: round trips for every
// element type, endianness and encoding, and one test per kind of bad file.
#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <string>

#include "dentar/volume/image_volume.h"
#include "testutil.h"

namespace dentar::volume {
namespace {

namespace fs = std::filesystem;

ImageVolume make_volume(ElementType t, Eigen::Vector3i dims = {5, 4, 3}) {
  ImageVolume v;
  v.geometry.dims = dims;
  v.geometry.spacing = {1e-4, 2e-4, 2.5e-4};
  v.geometry.origin = {-1e-3, 2e-3, 0.5e-3};
  v.source_type = t;
  v.values.resize(static_cast<std::size_t>(v.geometry.voxel_count()));
  const bool is_signed = t == ElementType::kInt8 || t == ElementType::kInt16 ||
                         t == ElementType::kInt32 || t == ElementType::kFloat32 ||
                         t == ElementType::kFloat64;
  const bool is_float = t == ElementType::kFloat32 || t == ElementType::kFloat64;
  for (std::size_t i = 0; i < v.values.size(); ++i) {
    float x = static_cast<float>((i * 37) % 120);
    if (is_signed) x -= 60;
    if (is_float) x += 0.25f;
    v.values[i] = x;
  }
  // Use the high byte of wide types so byte order matters.
  if (element_size(t) >= 2 && !is_float) v.values[1] = t == ElementType::kInt16 ? -30000 : 60000;
  return v;
}

void expect_same(const ImageVolume& a, const ImageVolume& b) {
  EXPECT_EQ(a.geometry.dims, b.geometry.dims);
  EXPECT_TRUE(a.geometry.spacing.isApprox(b.geometry.spacing, 1e-12));
  EXPECT_LT((a.geometry.origin - b.geometry.origin).norm(), 1e-12);
  EXPECT_EQ(a.source_type, b.source_type);
  EXPECT_EQ(a.values, b.values);
}

// Expects the error to name the file and contain `problem`.
void expect_error(const Result<ImageVolume>& r, const std::string& file,
                  const std::string& problem) {
  ASSERT_FALSE(r.ok()) << "expected an error about " << problem;
  EXPECT_NE(r.error().find(file), std::string::npos) << r.error();
  EXPECT_NE(r.error().find(problem), std::string::npos) << r.error();
}

std::string replace(std::string s, const std::string& from, const std::string& to) {
  const auto p = s.find(from);
  EXPECT_NE(p, std::string::npos) << "'" << from << "' not in:\n" << s;
  if (p != std::string::npos) s.replace(p, from.size(), to);
  return s;
}

constexpr ElementType kAllTypes[] = {
    ElementType::kUInt8,  ElementType::kInt8,  ElementType::kUInt16,  ElementType::kInt16,
    ElementType::kUInt32, ElementType::kInt32, ElementType::kFloat32, ElementType::kFloat64};

TEST(ImageIo, ElementTypeNamesAndSizes) {
  EXPECT_EQ(element_type_name(ElementType::kInt16), "int16");
  EXPECT_EQ(element_type_name(ElementType::kFloat64), "float64");
  EXPECT_EQ(element_size(ElementType::kUInt8), 1u);
  EXPECT_EQ(element_size(ElementType::kFloat32), 4u);
  EXPECT_EQ(element_size(ElementType::kFloat64), 8u);
}

TEST(ImageIo, RoundTripAllFormatsTypesEndiansAndEncodings) {
  const fs::path dir = test::temp_dir("rt");
  int n = 0;
  for (const ElementType t : kAllTypes) {
    const ImageVolume v = make_volume(t);
    for (const bool big : {false, true}) {
      for (const bool gz : {false, true}) {
        for (const std::string ext : {".json", ".mha", ".mhd", ".nrrd", ".nhdr"}) {
          if (ext == ".json" && gz) continue;
          std::string name =
              std::to_string(n++);  // (not "v" + ...: GCC 12 -Wrestrict false positive)
          name.insert(0, 1, 'v');
          name += ext;
          const std::string path = (dir / name).string();
          SCOPED_TRACE(path + " " + std::string(element_type_name(t)) + (big ? " big" : " little") +
                       (gz ? " gzip" : ""));
          const WriteOptions o{big, gz};
          Status s = ext == ".json"                     ? write_raw_json(v, path, o)
                     : (ext == ".mha" || ext == ".mhd") ? write_metaimage(v, path, o)
                                                        : write_nrrd(v, path, o);
          ASSERT_TRUE(s.ok()) << s.error();
          auto r = load_volume(path);
          ASSERT_TRUE(r.ok()) << r.error();
          expect_same(v, *r);
        }
      }
    }
  }
}

TEST(ImageIo, ByteOrderIsHonoured) {
  const fs::path dir = test::temp_dir("endian");
  ImageVolume v = make_volume(ElementType::kUInt16, {2, 1, 1});
  v.values = {258, 1};  // 0x0102, 0x0001
  ASSERT_TRUE(write_raw_json(v, (dir / "b.json").string(), {true, false}).ok());
  const std::string raw = test::read_file(dir / "b.raw");
  ASSERT_EQ(raw.size(), 4u);
  EXPECT_EQ(raw[0], 1);
  EXPECT_EQ(raw[1], 2);
  // The same bytes read as little endian give other numbers.
  std::string json = test::read_file(dir / "b.json");
  test::write_file(dir / "b.json", replace(json, "\"big\"", "\"little\""));
  auto r = load_raw_json((dir / "b.json").string());
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r->values[0], 513.0f);
  EXPECT_EQ(r->values[1], 256.0f);
}

TEST(ImageIo, UnitsAreMillimetresInFilesAndMetresInCode) {
  const fs::path dir = test::temp_dir("units");
  test::write_file(dir / "a.raw", std::string(24, '\x07'));
  test::write_file(dir / "a.json",
                   R"({"format":"dentar-raw","version":1,"data":"a.raw","dims":[4,3,2],)"
                   R"("type":"uint8","spacing_mm":[0.1,0.2,0.3],"origin_mm":[1,2,3]})");
  auto r = load_volume((dir / "a.json").string());
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_NEAR(r->geometry.spacing.x(), 1e-4, 1e-15);
  EXPECT_NEAR(r->geometry.spacing.z(), 3e-4, 1e-15);
  EXPECT_NEAR(r->geometry.origin.y(), 2e-3, 1e-15);
  EXPECT_EQ(r->at(3, 2, 1), 7.0f);
}

TEST(ImageIo, SkipsAndDataAtEnd) {
  const fs::path dir = test::temp_dir("skip");
  const ImageVolume v = make_volume(ElementType::kInt16);
  // Raw sidecar with header_bytes.
  ASSERT_TRUE(write_raw_json(v, (dir / "a.json").string()).ok());
  test::write_file(dir / "a.raw", "0123456789abcdef" + test::read_file(dir / "a.raw"));
  test::write_file(dir / "a.json", replace(test::read_file(dir / "a.json"), "\"header_bytes\": 0",
                                           "\"header_bytes\": 16"));
  auto r = load_volume((dir / "a.json").string());
  ASSERT_TRUE(r.ok()) << r.error();
  expect_same(v, *r);
  // MetaImage HeaderSize = -1: the data are the last bytes of the file.
  ASSERT_TRUE(write_metaimage(v, (dir / "m.mhd").string()).ok());
  test::write_file(dir / "m.raw", "junk-junk" + test::read_file(dir / "m.raw"));
  test::write_file(dir / "m.mhd", replace(test::read_file(dir / "m.mhd"), "ElementDataFile",
                                          "HeaderSize = -1\nElementDataFile"));
  r = load_volume((dir / "m.mhd").string());
  ASSERT_TRUE(r.ok()) << r.error();
  expect_same(v, *r);
  // NRRD byte skip, applied after gzip decoding.
  ImageVolume g = v;
  ASSERT_TRUE(write_nrrd(g, (dir / "n.nrrd").string(), {false, false}).ok());
  std::string nrrd = test::read_file(dir / "n.nrrd");
  nrrd = replace(nrrd, "encoding: raw\n", "encoding: raw\nbyte skip: 3\n");
  const auto blank = nrrd.find("\n\n");
  nrrd.insert(blank + 2, "abc");
  test::write_file(dir / "n.nrrd", nrrd);
  r = load_volume((dir / "n.nrrd").string());
  ASSERT_TRUE(r.ok()) << r.error();
  expect_same(v, *r);
}

TEST(ImageIo, MetaImageAndNrrdHeaderVariants) {
  const fs::path dir = test::temp_dir("variants");
  test::write_file(dir / "d.raw", std::string(8, '\x05'));
  // MetaImage with ElementSize instead of ElementSpacing, comments, other keys.
  test::write_file(dir / "a.mhd",
                   "ObjectType = Image\nNDims = 3\nComment = hello\nDimSize = 2 2 2\n"
                   "ElementSize = 0.5 0.5 0.5\nAnatomicalOrientation = RAI\n"
                   "ElementType = MET_UCHAR\nElementDataFile = d.raw\n");
  auto r = load_volume((dir / "a.mhd").string());
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_NEAR(r->geometry.spacing.x(), 5e-4, 1e-15);
  // NRRD with spacings, space units m, a key/value pair and a comment.
  test::write_file(dir / "b.nhdr",
                   "NRRD0005\n# comment\ntype: unsigned char\ndimension: 3\nsizes: 2 2 2\n"
                   "spacings: 0.001 0.001 0.002\nspace units: \"m\" \"m\" \"m\"\n"
                   "my key:=my value\nencoding: raw\ndata file: d.raw\n");
  r = load_volume((dir / "b.nhdr").string());
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_NEAR(r->geometry.spacing.z(), 2e-3, 1e-15);
}

// ---- bad files ---------------------------------------------------------------

struct Fixture {
  fs::path dir;
  std::string path;
};

Fixture write_good(const std::string& tag, const std::string& ext,
                   ElementType t = ElementType::kUInt8, bool gz = false) {
  Fixture f{test::temp_dir(tag), {}};
  f.path = (f.dir / ("vol" + ext)).string();
  const ImageVolume v = make_volume(t, {6, 5, 4});
  const WriteOptions o{false, gz};
  Status s = ext == ".json"                     ? write_raw_json(v, f.path, o)
             : (ext == ".mha" || ext == ".mhd") ? write_metaimage(v, f.path, o)
                                                : write_nrrd(v, f.path, o);
  EXPECT_TRUE(s.ok()) << s.error();
  return f;
}

TEST(ImageIoBad, TruncatedData) {
  for (const std::string ext : {".json", ".mha", ".mhd", ".nrrd", ".nhdr"}) {
    Fixture f = write_good("trunc" + ext.substr(1), ext);
    const bool detached = ext == ".json" || ext == ".mhd" || ext == ".nhdr";
    const fs::path data = detached ? f.dir / "vol.raw" : fs::path(f.path);
    std::string bytes = test::read_file(data);
    bytes.resize(bytes.size() - 7);
    test::write_file(data, bytes);
    SCOPED_TRACE(ext);
    expect_error(load_volume(f.path), data.string(), "truncated data");
  }
}

TEST(ImageIoBad, DimsDoNotMatchTheSize) {
  for (const std::string ext : {".json", ".mha", ".mhd", ".nrrd", ".nhdr"}) {
    Fixture f = write_good("dims" + ext.substr(1), ext);
    const bool detached = ext == ".json" || ext == ".mhd" || ext == ".nhdr";
    const fs::path data = detached ? f.dir / "vol.raw" : fs::path(f.path);
    test::write_file(data, test::read_file(data) + "extra");
    SCOPED_TRACE(ext);
    expect_error(load_volume(f.path), data.string(), "dims do not match the data size");
  }
}

TEST(ImageIoBad, DimsOverLimitsAreRefusedBeforeAllocating) {
  Fixture f = write_good("limits_json", ".json");
  std::string json = test::read_file(f.path);
  test::write_file(f.path, replace(json, "6,", "5000,"));
  expect_error(load_volume(f.path), f.path, "outside [1, 4096]");
  // 4096^3 voxels: each dim is allowed, the product is not.
  Fixture m = write_good("limits_mha", ".mha");
  test::write_file(m.path,
                   replace(test::read_file(m.path), "DimSize = 6 5 4", "DimSize = 4096 4096 4096"));
  expect_error(load_volume(m.path), m.path, "exceed the limit");
  // Allowed dims (1 GiB of float64) over a tiny attached payload: refused by size.
  Fixture n = write_good("limits_nrrd", ".nrrd");
  test::write_file(n.path, replace(test::read_file(n.path), "sizes: 6 5 4", "sizes: 4096 4096 64"));
  expect_error(load_volume(n.path), n.path, "truncated data");
}

TEST(ImageIoBad, UnknownElementType) {
  Fixture f = write_good("type_json", ".json");
  test::write_file(f.path, replace(test::read_file(f.path), "\"uint8\"", "\"int64\""));
  expect_error(load_volume(f.path), f.path, "unknown element type");
  Fixture m = write_good("type_mha", ".mha");
  test::write_file(m.path, replace(test::read_file(m.path), "MET_UCHAR", "MET_LONG_LONG"));
  expect_error(load_volume(m.path), m.path, "unknown or unsupported ElementType");
  Fixture n = write_good("type_nrrd", ".nrrd");
  test::write_file(n.path, replace(test::read_file(n.path), "type: uint8", "type: block"));
  expect_error(load_volume(n.path), n.path, "unknown or unsupported element type");
}

TEST(ImageIoBad, BadSpacing) {
  Fixture f = write_good("sp_json", ".json");
  const std::string json = test::read_file(f.path);
  const std::string sp = json.substr(json.find("\"spacing_mm\""));
  const std::string sp_line = sp.substr(0, sp.find(']') + 1);
  test::write_file(f.path, replace(json, sp_line, "\"spacing_mm\": [0.1, 0, 0.1]"));
  expect_error(load_volume(f.path), f.path, "spacing_mm");
  test::write_file(f.path, replace(json, sp_line, "\"spacing_mm\": [0.1, -0.2, 0.1]"));
  expect_error(load_volume(f.path), f.path, "must be > 0");
  test::write_file(f.path, replace(json, sp_line, "\"spacing_mm\": [0.1, null, 0.1]"));
  expect_error(load_volume(f.path), f.path, "array of 3 numbers");

  Fixture m = write_good("sp_mha", ".mha");
  const std::string mha = test::read_file(m.path);
  const std::string line =
      mha.substr(mha.find("ElementSpacing"),
                 mha.find('\n', mha.find("ElementSpacing")) - mha.find("ElementSpacing"));
  test::write_file(m.path, replace(mha, line, "ElementSpacing = nan 0.1 0.1"));
  expect_error(load_volume(m.path), m.path, "must be finite");
  test::write_file(m.path, replace(mha, line, "ElementSpacing = 0.1 0 0.1"));
  expect_error(load_volume(m.path), m.path, "must be > 0");
  test::write_file(m.path, replace(mha, line, "ElementSpacing = 0.1 -1 0.1"));
  expect_error(load_volume(m.path), m.path, "must be > 0");

  Fixture n = write_good("sp_nrrd", ".nhdr");
  const std::string nh = test::read_file(n.path);
  const std::string dl =
      nh.substr(nh.find("space directions"),
                nh.find('\n', nh.find("space directions")) - nh.find("space directions"));
  test::write_file(n.path, replace(nh, dl, "spacings: 0.1 nan 0.1"));
  expect_error(load_volume(n.path), n.path, "must be a finite number > 0");
  test::write_file(n.path, replace(nh, dl, "spacings: 0.1 0.1 0"));
  expect_error(load_volume(n.path), n.path, "must be a finite number > 0");
  test::write_file(n.path, replace(nh, dl, "space directions: (-0.1,0,0) (0,0.1,0) (0,0,0.1)"));
  expect_error(load_volume(n.path), n.path, "must be > 0");
}

TEST(ImageIoBad, RotatedVolumesAreRefused) {
  Fixture n = write_good("rot_nrrd", ".nrrd");
  const std::string nh = test::read_file(n.path);
  const std::string dl =
      nh.substr(nh.find("space directions"),
                nh.find('\n', nh.find("space directions")) - nh.find("space directions"));
  test::write_file(n.path,
                   replace(nh, dl, "space directions: (0.07,0.07,0) (-0.07,0.07,0) (0,0,0.1)"));
  expect_error(load_volume(n.path), n.path, "not axis-aligned: rotated volumes are not supported");
  Fixture m = write_good("rot_mha", ".mha");
  test::write_file(m.path, replace(test::read_file(m.path), "TransformMatrix = 1 0 0 0 1 0 0 0 1",
                                   "TransformMatrix = 0 1 0 -1 0 0 0 0 1"));
  expect_error(load_volume(m.path), m.path, "rotated or flipped volumes are not supported");
}

TEST(ImageIoBad, NonFiniteVoxelValues) {
  Fixture f = write_good("nan_json", ".json", ElementType::kFloat32);
  std::string raw = test::read_file(f.dir / "vol.raw");
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(raw.data() + 4 * 7, &nan, 4);  // voxel (1,1,0) of 6x5x4
  test::write_file(f.dir / "vol.raw", raw);
  expect_error(load_volume(f.path), (f.dir / "vol.raw").string(), "non-finite float32 voxel value");
  EXPECT_NE(load_volume(f.path).error().find("(1,1,0)"), std::string::npos);
  // float64 beyond the float range would become inf silently.
  Fixture d = write_good("big_nrrd", ".nrrd", ElementType::kFloat64);
  std::string nr = test::read_file(d.path);
  const double huge = 1e300;
  std::memcpy(nr.data() + nr.size() - 8, &huge, 8);
  test::write_file(d.path, nr);
  expect_error(load_volume(d.path), d.path, "non-finite float64 voxel value");
}

TEST(ImageIoBad, CorruptGzip) {
  Fixture n = write_good("gz_nrrd", ".nrrd", ElementType::kUInt8, true);
  const std::string good = test::read_file(n.path);
  const std::size_t data = good.find("\n\n") + 2;
  std::string bad = good;
  for (std::size_t i = data + 10; i < data + 16 && i < bad.size(); ++i) bad[i] ^= 0x5a;
  test::write_file(n.path, bad);
  expect_error(load_volume(n.path), n.path, "corrupt gzip data");
  test::write_file(n.path, good.substr(0, good.size() - 12));
  expect_error(load_volume(n.path), n.path, "corrupt gzip data");
  Fixture m = write_good("gz_mhd", ".mhd", ElementType::kInt16, true);
  const fs::path z = m.dir / "vol.zraw";
  test::write_file(z, "not a gzip stream at all");
  expect_error(load_volume(m.path), z.string(), "corrupt gzip data");
}

TEST(ImageIoBad, GzipBombIsRefusedWithoutInflatingIt) {
  // 64 MiB of zeros compress to ~64 KiB; the header declares 6x5x4 bytes.
  const std::string zeros(64u << 20, '\0');
  uLongf len = compressBound(static_cast<uLong>(zeros.size()));
  std::string z(len, '\0');
  ASSERT_EQ(
      compress2(reinterpret_cast<Bytef*>(z.data()), &len,
                reinterpret_cast<const Bytef*>(zeros.data()), static_cast<uLong>(zeros.size()), 9),
      Z_OK);
  z.resize(len);
  const fs::path dir = test::temp_dir("bomb");
  const std::string path = (dir / "bomb.nrrd").string();
  test::write_file(path,
                   "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 6 5 4\nspacings: 0.1 0.1 0.1\n"
                   "encoding: gzip\n\n" +
                       z);
  expect_error(load_volume(path), path, "inflates to more than the 120 bytes");
}

TEST(ImageIoBad, MissingDataFile) {
  for (const std::string ext : {".json", ".mhd", ".nhdr"}) {
    Fixture f = write_good("missing" + ext.substr(1), ext);
    fs::remove(f.dir / "vol.raw");
    SCOPED_TRACE(ext);
    const auto r = load_volume(f.path);
    expect_error(r, (f.dir / "vol.raw").string(), "does not exist");
    EXPECT_NE(r.error().find(f.path), std::string::npos) << "names the header too: " << r.error();
  }
  expect_error(load_volume("/nonexistent/x.nrrd"), "/nonexistent/x.nrrd", "does not exist");
}

TEST(ImageIoBad, MalformedHeaders) {
  const fs::path dir = test::temp_dir("malformed");
  const auto check = [&](const std::string& file, const std::string& text,
                         const std::string& problem) {
    const std::string p = (dir / file).string();
    test::write_file(p, text);
    SCOPED_TRACE(file);
    expect_error(load_volume(p), p, problem);
  };
  check("a.json", "{\"format\": \"dentar-raw\", ", "invalid JSON");
  check("b.json", "[1,2,3]", "must be a JSON object");
  check(
      "c.json",
      R"({"format":"dentar-raw","version":1,"data":"x.raw","dims":[1,1,1],"type":"uint8","spacing":[1,1,1]})",
      "unknown key");
  check("d.json", R"({"format":"dentar-raw","version":2})", "version");
  check("e.mha", "NDims = 2\nDimSize = 4 4\nElementDataFile = LOCAL\n", "only 3-D images");
  check("f.mha", "NDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\nElementDataFile = LOCAL\n",
        "missing ElementSpacing");
  check("g.mha", "NDims = 3\nDimSize = 2 2 2\n", "without an ElementDataFile");
  check("h.mhd",
        "NDims = 3\nDimSize = 2 2 2\nElementSpacing = 1 1 1\nElementType = MET_UCHAR\n"
        "ElementDataFile = slice%03d.raw 1 2 1\n",
        "patterns are not supported");
  check("i.nrrd", "P5\n2 2\n", "not a NRRD file");
  check("j.nrrd",
        "NRRD0004\ntype: uint16\ndimension: 3\nsizes: 2 2 2\nspacings: 1 1 1\nencoding: raw\n\n"
        "12345678",
        "missing field 'endian'");
  check("k.nrrd",
        "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nspacings: 1 1 1\nencoding: ascii\n\n",
        "encoding 'ascii' is not supported");
  check("l.nrrd", "NRRD0004\ntype: uint8\ndimension: 4\n", "only 3-D scalar volumes");
  check("m.nrrd", "NRRD0004\ntype: uint8\nfrobnicate: 3\n", "unknown field 'frobnicate'");
  check("n.vtk", "whatever", "unknown volume extension");
}

TEST(ImageIoWrite, RefusesValuesTheTypeCannotHold) {
  const fs::path dir = test::temp_dir("write");
  ImageVolume v = make_volume(ElementType::kUInt8);
  v.values[3] = 256;
  Status s = write_nrrd(v, (dir / "a.nrrd").string());
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("not representable as uint8"), std::string::npos) << s.error();
  v.values[3] = 1.5f;
  EXPECT_FALSE(write_raw_json(v, (dir / "a.json").string()).ok());
  EXPECT_FALSE(write_metaimage(v, (dir / "a.vtk").string()).ok());
}

TEST(ImageIoMemory, ParsersWorkOnBytesAndReportHeaderLength) {
  const std::string head =
      "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 1 1\nspacings: 1 1 1\nencoding: raw\n\n";
  const std::string file = head + "\x01\x02";
  std::size_t hb = 0;
  auto h = parse_nrrd_header(file, "mem.nrrd", &hb);
  ASSERT_TRUE(h.ok()) << h.error();
  EXPECT_EQ(hb, head.size());
  auto v = decode_volume_data(
      *h, std::span(reinterpret_cast<const std::uint8_t*>(file.data()) + hb, 2), "mem.nrrd");
  ASSERT_TRUE(v.ok()) << v.error();
  EXPECT_EQ(v->values, (std::vector<float>{1, 2}));
}

}  // namespace
}  // namespace dentar::volume
