#include "dentar/training/kinematics.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include "testutil.h"

namespace dentar::training {
namespace {

const char* kQuatMap = R"({"time": "t", "position": ["x", "y", "z"], "quaternion": ["qw", "qx", "qy", "qz"],
                           "force": ["fx", "fy", "fz"], "gripper": "g", "position_scale": 1000})";

TEST(Kinematics, CsvWithQuaternionAndTimeColumn) {
  auto map = parse_column_map(kQuatMap, "map.json");
  ASSERT_TRUE(map.ok()) << map.error();
  // 90 degrees about x: the tool axis (+z) becomes -y.
  const double h = std::sqrt(0.5);
  const std::string csv = "t,x,y,z,qw,qx,qy,qz,fx,fy,fz,g\n"
                          "0.0,0.001,0.002,0.003,1,0,0,0,0.1,0.2,0.3,0.5\n"
                          "0.02,0.002,0.002,0.003," + std::to_string(h) + "," + std::to_string(h) + ",0,0,0,0,1,0.4\n"
                          "0.04,0.003,0.002,0.003,1,0,0,0,0,0,2,0.3\n";
  auto t = parse_kinematics(csv, "trial.csv", *map);
  ASSERT_TRUE(t.ok()) << t.error();
  ASSERT_EQ(t->x.rows(), 3);
  ASSERT_EQ(t->x.cols(), 10);
  EXPECT_NEAR(t->rate_hz, 50.0, 1e-9);
  EXPECT_NEAR(t->x(0, 0), 1.0, 1e-12);  // mm
  EXPECT_NEAR(t->x(1, 4), -1.0, 1e-6);  // axis_y
  EXPECT_NEAR(t->x(1, 5), 0.0, 1e-6);
  EXPECT_NEAR(t->x(2, 8), 2.0, 1e-12);
  EXPECT_NEAR(t->x(2, 9), 0.3, 1e-12);
  EXPECT_EQ(t->feature_names[9], "gripper");
}

TEST(Kinematics, WhitespaceTableWithRotationMatrixByColumnNumber) {
  // JIGSAWS-like layout without a header: position in columns 1-3, rotation
  // matrix (row major) in 4-12, gripper in 13.
  auto map = parse_column_map(R"({"header": false, "rate_hz": 30, "delimiter": "whitespace",
      "position": [1, 2, 3], "matrix": [4,5,6,7,8,9,10,11,12], "gripper": 13})", "map.json");
  ASSERT_TRUE(map.ok()) << map.error();
  // Rotation of 90 degrees about y: R = [[0,0,1],[0,1,0],[-1,0,0]]: axis (+z column) = (1, 0, 0).
  const std::string txt = "0.1 0.2 0.3  0 0 1 0 1 0 -1 0 0  0.5\n"
                          "0.1 0.2 0.4  1 0 0 0 1 0 0 0 1   0.6\n";
  auto t = parse_kinematics(txt, "trial.txt", *map);
  ASSERT_TRUE(t.ok()) << t.error();
  EXPECT_NEAR(t->rate_hz, 30, 1e-12);
  EXPECT_NEAR(t->x(0, 3), 1.0, 1e-12);
  EXPECT_NEAR(t->x(0, 5), 0.0, 1e-12);
  EXPECT_NEAR(t->x(1, 5), 1.0, 1e-12);
  EXPECT_NEAR(t->x(1, 6), 0.6, 1e-12);
  // Not a rotation (a column scaled): a clear message.
  auto bad = parse_kinematics("0 0 0  2 0 0 0 1 0 0 0 1  0\n0 0 0  1 0 0 0 1 0 0 0 1  0\n", "trial.txt", *map);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("trial.txt: data row 1"), std::string::npos) << bad.error();
  EXPECT_NE(bad.error().find("not a rotation"), std::string::npos) << bad.error();
}

TEST(Kinematics, BadTablesNameFileLineAndColumn) {
  auto map = parse_column_map(kQuatMap, "map.json");
  ASSERT_TRUE(map.ok());
  auto missing = parse_kinematics("t,x,y,z,qw,qx,qy,fx,fy,fz,g\n0,0,0,0,1,0,0,0,0,0,0\n1,0,0,0,1,0,0,0,0,0,0\n", "a.csv", *map);
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().find("a.csv: line 1: the quaternion column 'qz'"), std::string::npos) << missing.error();
  auto ragged = parse_kinematics("t,x,y,z,qw,qx,qy,qz,fx,fy,fz,g\n0,0,0,0,1,0,0,0,0,0,0,0\n1,0,0,0,1,0,0,0,0,0\n", "b.csv", *map);
  ASSERT_FALSE(ragged.ok());
  EXPECT_NE(ragged.error().find("b.csv: line 3: 10 columns, expected 12"), std::string::npos) << ragged.error();
  auto text = parse_kinematics("t,x,y,z,qw,qx,qy,qz,fx,fy,fz,g\n0,0,abc,0,1,0,0,0,0,0,0,0\n", "c.csv", *map);
  ASSERT_FALSE(text.ok());
  EXPECT_NE(text.error().find("c.csv: line 2, column 3 ('y'): 'abc' is not a finite number"), std::string::npos) << text.error();
  auto nomap = parse_column_map(R"({"position": ["x", "y"]})", "m.json");
  ASSERT_FALSE(nomap.ok());
  EXPECT_NE(nomap.error().find("m.json: field 'position'"), std::string::npos);
}

TEST(Kinematics, TrialsTableFeedsCrossValidation) {
  // Six subjects, two trials each: "expert" moves smoothly, "novice" jitters.
  const std::string dir = dentar::test::temp_dir("kin").string();
  std::filesystem::create_directories(dir);
  std::ofstream trials(dir + "/trials.csv");
  trials << "file,subject,trial,label\n";
  for (int s = 0; s < 6; ++s)
    for (int tr = 0; tr < 2; ++tr) {
      const bool expert = s < 3;
      const std::string f = "s" + std::to_string(s) + "_" + std::to_string(tr) + ".csv";
      std::ofstream k(dir + "/" + f);
      k << "t,x,y,z,qw,qx,qy,qz,fx,fy,fz,g\n";
      for (int i = 0; i < 300; ++i) {
        const double u = i / 300.0;
        const double j = expert ? 0.0 : 0.002 * std::sin(i * (2.1 + s + tr));
        k << i * 0.01 << "," << 0.01 * u + j << "," << 0.005 * std::sin(3 * u) << "," << 0.002 * u + j << ",1,0,0,0,"
          << 0.1 * u << "," << (expert ? 0.5 : 1.5) + 0.1 * std::sin(i * 0.7 + s) << "," << -1.0 - u << "," << 0.3 + 0.1 * u << "\n";
      }
      trials << f << ",S" << s << "," << tr + 1 << "," << (expert ? "expert" : "novice") << "\n";
    }
  trials.close();
  auto map = parse_column_map(R"({"time": "t", "position": ["x", "y", "z"], "force": ["fx", "fy", "fz"], "gripper": "g", "position_scale": 1000})", "m.json");
  ASSERT_TRUE(map.ok()) << map.error();
  std::vector<std::string> names;
  auto t = import_trials(dir + "/trials.csv", *map, &names);
  ASSERT_TRUE(t.ok()) << t.error();
  ASSERT_EQ(t->size(), 12u);
  AssessOptions o;
  o.method = Method::kGaussianHmm;
  o.states = 3;
  auto cv = cross_validate_subjects(*t, names, o);
  ASSERT_TRUE(cv.ok()) << cv.error();
  EXPECT_EQ(cv->accuracy, 1.0);
}


// Issue 25, item 4: real tables as they come.

TEST(Kinematics, TwoToolsEachWithItsOwnColumns) {
  auto map = parse_column_map(R"({"rate_hz": 30, "pedal": "p",
      "tools": [{"name": "left", "position": ["lx", "ly", "lz"], "axis": ["lax", "lay", "laz"], "gripper": "lg"},
                {"name": "right", "position": [5, 6, 7], "force": ["rfx", "rfy", "rfz"]}]})", "two.json");
  ASSERT_TRUE(map.ok()) << map.error();
  ASSERT_EQ(map->tools.size(), 2u);
  const std::string csv = "lx,ly,lz,lg,rx,ry,rz,lax,lay,laz,rfx,rfy,rfz,p\n"
                          "1,2,3,0.5,4,5,6,0,0,2,0.1,0.2,0.3,1\n"
                          "1,2,4,0.6,4,5,7,0,3,0,0.1,0.2,0.4,0\n";
  auto t = parse_kinematics(csv, "two.csv", *map);
  ASSERT_TRUE(t.ok()) << t.error();
  const std::vector<std::string> want = {"left.pos_x_mm", "left.pos_y_mm", "left.pos_z_mm", "left.axis_x", "left.axis_y",
                                         "left.axis_z", "left.gripper", "right.pos_x_mm", "right.pos_y_mm", "right.pos_z_mm",
                                         "right.force_x_N", "right.force_y_N", "right.force_z_N", "pedal"};
  EXPECT_EQ(t->feature_names, want);
  EXPECT_NEAR(t->x(0, 5), 1.0, 1e-12);  // the axis is normalised
  EXPECT_NEAR(t->x(1, 4), 1.0, 1e-12);
  EXPECT_NEAR(t->x(1, 9), 7.0, 1e-12);  // right z by column number 7
  EXPECT_NEAR(t->x(1, 12), 0.4, 1e-12);
  EXPECT_NEAR(t->x(0, 13), 1.0, 1e-12);
  auto dup = parse_column_map(R"({"rate_hz": 30, "tools": [{"name": "a", "position": [1,2,3]}, {"name": "a", "position": [4,5,6]}]})", "d.json");
  ASSERT_FALSE(dup.ok());
  EXPECT_NE(dup.error().find("d.json: field 'tools[1].name': 'a' is used twice"), std::string::npos) << dup.error();
}

TEST(Kinematics, UnknownKeyInTheColumnMapIsAnErrorNamingTheFileAndKey) {
  auto top = parse_column_map(R"({"rate_hz": 30, "position": [1, 2, 3], "postion_scale": 1000})", "map.json");
  ASSERT_FALSE(top.ok());
  EXPECT_NE(top.error().find("map.json: unknown key 'postion_scale'"), std::string::npos) << top.error();
  auto tool = parse_column_map(R"({"rate_hz": 30, "tools": [{"name": "psm1", "position": [1, 2, 3], "grip": 4}]})", "m2.json");
  ASSERT_FALSE(tool.ok());
  EXPECT_NE(tool.error().find("m2.json: unknown key 'tools[0].grip'"), std::string::npos) << tool.error();
  // A long key is cut to a readable length.
  auto lng = parse_column_map("{\"rate_hz\": 30, \"position\": [1,2,3], \"" + std::string(500, 'k') + "\": 1}", "m3.json");
  ASSERT_FALSE(lng.ok());
  EXPECT_LT(lng.error().size(), 300u) << lng.error();
  EXPECT_NE(lng.error().find("(500 chars)"), std::string::npos) << lng.error();
}

TEST(Kinematics, AListWhereOneColumnOrANumberIsExpectedIsAnError) {
  auto time = parse_column_map(R"({"time": ["t"], "position": [1, 2, 3]})", "map.json");
  ASSERT_FALSE(time.ok());
  EXPECT_NE(time.error().find("map.json: field 'time': one column is expected (a name or a number), not a list"),
            std::string::npos) << time.error();
  auto grip = parse_column_map(R"({"rate_hz": 30, "position": [1, 2, 3], "gripper": [7, 8]})", "map.json");
  ASSERT_FALSE(grip.ok());
  EXPECT_NE(grip.error().find("field 'gripper'"), std::string::npos) << grip.error();
  auto nested = parse_column_map(R"({"rate_hz": 30, "position": [1, [2], 3]})", "map.json");
  ASSERT_FALSE(nested.ok());
  EXPECT_NE(nested.error().find("field 'position[1]': one column is expected"), std::string::npos) << nested.error();
  auto rate = parse_column_map(R"({"rate_hz": [30], "position": [1, 2, 3]})", "map.json");
  ASSERT_FALSE(rate.ok());
  EXPECT_NE(rate.error().find("map.json: field 'rate_hz': must be a number, not a list"), std::string::npos) << rate.error();
}

TEST(Kinematics, HeaderIsDetectedAndAFirstRowOfNumbersIsNeverDropped) {
  // header not given, the table has none: every row is data.
  auto byNumber = parse_column_map(R"({"rate_hz": 10, "position": [1, 2, 3]})", "map.json");
  ASSERT_TRUE(byNumber.ok()) << byNumber.error();
  EXPECT_EQ(byNumber->header, -1);
  auto t = parse_kinematics("1,2,3\n4,5,6\n7,8,9\n", "nohead.csv", *byNumber);
  ASSERT_TRUE(t.ok()) << t.error();
  ASSERT_EQ(t->x.rows(), 3);
  EXPECT_EQ(t->x(0, 0), 1.0);
  // header not given, the table has one: detected.
  auto named = parse_column_map(R"({"rate_hz": 10, "position": ["x", "y", "z"]})", "map.json");
  ASSERT_TRUE(named.ok());
  auto h = parse_kinematics("x,y,z\n1,2,3\n4,5,6\n", "head.csv", *named);
  ASSERT_TRUE(h.ok()) << h.error();
  EXPECT_EQ(h->x.rows(), 2);
  // No header, header unset, the map names columns: the message names the file, the key and what to do.
  auto none = parse_kinematics("1,2,3\n4,5,6\n", "trial7.csv", *named);
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.error().find("trial7.csv: the position column 'x' of the column map is not in the table: the table has no header"),
            std::string::npos) << none.error();
  EXPECT_NE(none.error().find("line 1, is all numbers and was kept as data"), std::string::npos) << none.error();
  // header: true on a first row of numbers: refused, not dropped.
  auto yes = parse_column_map(R"({"header": true, "rate_hz": 10, "position": [1, 2, 3]})", "map.json");
  ASSERT_TRUE(yes.ok());
  auto drop = parse_kinematics("1,2,3\n4,5,6\n7,8,9\n", "t.csv", *yes);
  ASSERT_FALSE(drop.ok());
  EXPECT_NE(drop.error().find("t.csv: line 1: the column map says \"header\": true, but this first line is all numbers"),
            std::string::npos) << drop.error();
  // header: false on a line of names.
  auto no = parse_column_map(R"({"header": false, "rate_hz": 10, "position": [1, 2, 3]})", "map.json");
  ASSERT_TRUE(no.ok());
  auto names = parse_kinematics("x,y,z\n4,5,6\n7,8,9\n", "u.csv", *no);
  ASSERT_FALSE(names.ok());
  EXPECT_NE(names.error().find("u.csv: line 1: the column map says \"header\": false"), std::string::npos) << names.error();
}

TEST(Kinematics, ErrorLinesAreCutToAReadableLength) {
  auto map = parse_column_map(R"({"rate_hz": 10, "position": ["x", "y", "z"]})", "map.json");
  ASSERT_TRUE(map.ok());
  const std::string junk(5000, 'q');
  auto t = parse_kinematics("x,y,z\n1,2,3\n1," + junk + ",3\n", "long.csv", *map);
  ASSERT_FALSE(t.ok());
  EXPECT_LT(t.error().size(), 200u) << t.error();
  EXPECT_NE(t.error().find("long.csv: line 3, column 2 ('y'): 'qqqq"), std::string::npos) << t.error();
  auto h = parse_kinematics(std::string(3000, 'h') + ",y,z\n1,2,3\n1,2,3\n", "wide.csv", *map);
  ASSERT_FALSE(h.ok());
  EXPECT_LT(h.error().size(), 300u) << h.error();
}

TEST(Kinematics, ThreeClassesWithOneMissingInAFoldNameTheLabelAndAFile) {
  // Two experts, two novices, one intermediate: leaving the intermediate
  // person out leaves no intermediate to train on.
  std::vector<Trial> trials;
  std::vector<std::string> names = {"pos_x_mm", "pos_y_mm", "pos_z_mm"};
  int k = 0;
  for (const auto& [subject, label] : std::vector<std::pair<std::string, std::string>>{
           {"E1", "expert"}, {"E2", "expert"}, {"N1", "novice"}, {"N2", "novice"}, {"I1", "intermediate"}})
    for (int tr = 1; tr <= 2; ++tr) {
      Trial t;
      t.subject = subject;
      t.label = label;
      t.trial = tr;
      t.source = "cohort/" + subject + "_t" + std::to_string(tr) + ".csv";
      t.x = Sequence::Random(50, 3) + Sequence::Constant(50, 3, ++k);
      trials.push_back(t);
    }
  AssessOptions o;
  o.method = Method::kTimePath;
  auto r = cross_validate(trials, names, o, CvMode::kSubject);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("label 'intermediate': leaving out person I1 leaves no 'intermediate' trial to train on"),
            std::string::npos) << r.error();
  EXPECT_NE(r.error().find("cohort/I1_t1.csv"), std::string::npos) << r.error();
  // Leaving trials out keeps every label: that works (and can measure identity).
  auto byTrial = cross_validate(trials, names, o, CvMode::kTrial);
  EXPECT_TRUE(byTrial.ok()) << byTrial.error();
}

}  // namespace
}  // namespace dentar::training
