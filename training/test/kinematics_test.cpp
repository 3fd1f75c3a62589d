#include "dentar/training/kinematics.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>

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
  const std::string dir = ::testing::TempDir() + "/dentar_kin_test_" + std::to_string(::getpid());
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

}  // namespace
}  // namespace dentar::training
