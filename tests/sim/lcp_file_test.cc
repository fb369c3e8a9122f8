// Tests of the plain-text LCP format (docs/lcp-format.md): valid files in any layout, every
// rejection with its exact message and line, bit-exact round trips through WriteLcpFile, the
// vector (warm start) files, and the bundled examples/lcp problems against their documented
// solutions.
#include "vinci/sim/solvers/lcp_file.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <ostream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "vinci/sim/solvers/lcp.h"
#include "vinci/sim/solvers/lemke.h"

namespace vinci::sim {
namespace {

// The message of the std::invalid_argument thrown by ParseLcp(text, "f.lcp"), or "" if none.
std::string ParseError(const std::string& text) {
  try {
    ParseLcp(text, "f.lcp");
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

std::string VectorError(const std::string& text, int n) {
  try {
    ParseLcpVector(text, n, "z.txt");
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

// Bit-for-bit equality (distinguishes -0.0 from 0.0, unlike ==).
bool SameBits(double a, double b) { return std::memcmp(&a, &b, sizeof(double)) == 0; }

void ExpectSameBits(const LcpProblem& a, const LcpProblem& b) {
  ASSERT_EQ(a.M.rows(), b.M.rows());
  ASSERT_EQ(a.M.cols(), b.M.cols());
  ASSERT_EQ(a.q.size(), b.q.size());
  for (Eigen::Index i = 0; i < a.M.rows(); ++i) {
    for (Eigen::Index j = 0; j < a.M.cols(); ++j)
      EXPECT_TRUE(SameBits(a.M(i, j), b.M(i, j))) << "M(" << i << ", " << j << ")";
    EXPECT_TRUE(SameBits(a.q(i), b.q(i))) << "q(" << i << ")";
  }
}

std::string ExamplePath(const std::string& name) {
  return std::string(VINCI_SOURCE_DIR) + "/examples/lcp/" + name;
}

TEST(LcpFileTest, ParsesOneByOne) {
  const LcpProblem p = ParseLcp("1\n1\n-9.8\n");
  ASSERT_EQ(p.size(), 1);
  ASSERT_EQ(p.M.rows(), 1);
  ASSERT_EQ(p.M.cols(), 1);
  EXPECT_EQ(p.M(0, 0), 1.0);
  EXPECT_EQ(p.q(0), -9.8);
  EXPECT_TRUE(p.blocks.empty());
}

// M is read row by row: the second number is M(0, 1), not M(1, 0).
TEST(LcpFileTest, ReadsMRowMajor) {
  const LcpProblem p = ParseLcp("2  1 2 3 4  5 6");
  MatrixXd M(2, 2);
  M << 1, 2, 3, 4;
  EXPECT_EQ(p.M, M);
  EXPECT_EQ(p.q, Eigen::Vector2d(5, 6));
}

// The same problem in very different layouts reads identically.
TEST(LcpFileTest, AnyLayoutCommentsAndBlankLines) {
  const LcpProblem reference = ParseLcp("3 1 2 0 0 1 2 2 0 1 -1 -1 -1");
  const std::vector<std::string> layouts = {
      // Row by row, comments, blank lines, no final newline.
      "# cycling example\n\n3   # n\n\n1 2 0\n0 1 2 # row 2\n2 0 1\n\n# q\n-1 -1 -1",
      // One number per line, CRLF line ends, tabs, a comment glued to a number.
      "3\r\n1\r\n2\r\n0\r\n0\t1\t2\r\n2\r\n0\r\n1#c\r\n-1\r\n-1\r\n-1\r\n",
      // Rows split across lines, spellings of the same numbers.
      "+3\n1.0 2e0\n0 0.0 +1 20e-1 2.\n0.0e5 1\n-1. -.1e1\n-1\n# trailing comment\n\n",
  };
  for (const std::string& text : layouts) {
    SCOPED_TRACE(text);
    ExpectSameBits(ParseLcp(text), reference);
  }
  MatrixXd M(3, 3);
  M << 1, 2, 0, 0, 1, 2, 2, 0, 1;
  EXPECT_EQ(reference.M, M);
  EXPECT_EQ(reference.q, -Eigen::Vector3d::Ones());
}

TEST(LcpFileTest, ReadsExtremeButFiniteNumbers) {
  const LcpProblem p = ParseLcp("2\n1.7976931348623157e308 -5e-324\n-0 1e-300\n0.1 -1e308\n");
  EXPECT_EQ(p.M(0, 0), std::numeric_limits<double>::max());
  EXPECT_EQ(p.M(0, 1), -std::numeric_limits<double>::denorm_min());
  EXPECT_TRUE(std::signbit(p.M(1, 0)));
  EXPECT_EQ(p.M(1, 1), 1e-300);
  EXPECT_EQ(p.q(0), 0.1);
  EXPECT_EQ(p.q(1), -1e308);
}

struct BadCase {
  const char* name;
  std::string text;
  std::string message;  // the exact what() for source name "f.lcp"
};
void PrintTo(const BadCase& c, std::ostream* os) { *os << c.name; }

class LcpFileRejects : public ::testing::TestWithParam<BadCase> {};

TEST_P(LcpFileRejects, WithLineAndExpectation) {
  EXPECT_EQ(ParseError(GetParam().text), GetParam().message);
}

const char kSizeExpected[] = "expected the problem size n, an integer from 1 to 100000, got ";

INSTANTIATE_TEST_SUITE_P(
    LcpFileTest, LcpFileRejects,
    ::testing::Values(
        // The size n.
        BadCase{"Empty", "",
                std::string("f.lcp:1: ") + kSizeExpected + "the end of the file (no numbers)"},
        BadCase{"OnlyComments", "# nothing\n\n# here\n",
                std::string("f.lcp:3: ") + kSizeExpected + "the end of the file (no numbers)"},
        BadCase{"SizeZero", "\n0\n", std::string("f.lcp:2: ") + kSizeExpected + "'0'"},
        BadCase{"SizeNegative", "-2\n1 0 0 1\n1 1\n",
                std::string("f.lcp:1: ") + kSizeExpected + "'-2'"},
        BadCase{"SizeNotInteger", "# n\n2.0\n1 0 0 1\n1 1\n",
                std::string("f.lcp:2: ") + kSizeExpected + "'2.0'"},
        BadCase{"SizeExponent", "1e1\n", std::string("f.lcp:1: ") + kSizeExpected + "'1e1'"},
        BadCase{"SizeText", "abc\n", std::string("f.lcp:1: ") + kSizeExpected + "'abc'"},
        BadCase{"SizeTooLarge", "100001\n", std::string("f.lcp:1: ") + kSizeExpected + "'100001'"},
        BadCase{"SizeOverflows", "99999999999999999999999\n",
                std::string("f.lcp:1: ") + kSizeExpected + "'99999999999999999999999'"},
        BadCase{"Bom",
                "\xEF\xBB\xBF"
                "1\n1\n1\n",
                std::string("f.lcp:1: ") + kSizeExpected + "'\\xef\\xbb\\xbf1'"},
        // Entries of M and q.
        BadCase{"TextInM", "2\n1 2\n3 abc\n5 6\n",
                "f.lcp:3: expected a finite number for entry (2, 2) of M, got 'abc'"},
        BadCase{"TextInQ", "2\n1 2 3 4\n# q\n5 x6\n",
                "f.lcp:4: expected a finite number for entry 2 of q, got 'x6'"},
        BadCase{"NumberWithJunk", "1\n1,5\n1\n",
                "f.lcp:2: expected a finite number for entry (1, 1) of M, got '1,5'"},
        BadCase{"HexNumber", "1\n0x10\n1\n",
                "f.lcp:2: expected a finite number for entry (1, 1) of M, got '0x10'"},
        BadCase{"NaN", "2\n1 0\n0 1\nnan 1\n",
                "f.lcp:4: expected a finite number for entry 1 of q, got 'nan'"},
        BadCase{"Inf", "2\n1 inf\n0 1\n1 1\n",
                "f.lcp:2: expected a finite number for entry (1, 2) of M, got 'inf'"},
        BadCase{"MinusInfinity", "2\n1 0\n-infinity 1\n1 1\n",
                "f.lcp:3: expected a finite number for entry (2, 1) of M, got '-infinity'"},
        BadCase{"Overflow", "1\n1e400\n1\n",
                "f.lcp:2: expected a finite number for entry (1, 1) of M, got '1e400' (outside "
                "the range of double)"},
        BadCase{"Underflow", "1\n1\n1e-400\n",
                "f.lcp:3: expected a finite number for entry 1 of q, got '1e-400' (outside the "
                "range of double)"},
        BadCase{"LongTokenTruncated", "1\n" + std::string(50, 'y') + "\n1\n",
                "f.lcp:2: expected a finite number for entry (1, 1) of M, got '" +
                    std::string(40, 'y') + "...'"},
        // Too few numbers: reported at the last line of the file.
        BadCase{"TooFew", "2\n1 2\n3 4\n5\n",
                "f.lcp:4: expected 4 entries of M and 2 of q after n = 2, got the end of the "
                "file after 5 numbers"},
        BadCase{"TooFewTrailingComments", "2\n1 2\n3 4\n5\n\n# the end\n",
                "f.lcp:6: expected 4 entries of M and 2 of q after n = 2, got the end of the "
                "file after 5 numbers"},
        BadCase{"OnlySize", "1\n",
                "f.lcp:1: expected 1 entry of M and 1 of q after n = 1, got the end of the file "
                "after 0 numbers"},
        BadCase{"QMissing", "3\n1 2 0\n0 1 2\n2 0 1",
                "f.lcp:4: expected 9 entries of M and 3 of q after n = 3, got the end of the "
                "file after 9 numbers"},
        // Too many.
        BadCase{"ExtraNumber", "2\n1 2\n3 4\n5 6\n\n# more\n7\n",
                "f.lcp:7: expected the end of the file after the 2 entries of q, got an extra "
                "number '7'"},
        BadCase{"ExtraText", "1\n1\n1 end\n",
                "f.lcp:3: expected the end of the file after the 1 entry of q, got 'end'"},
        BadCase{"ExtraNaN", "1\n1\n1\nnan\n",
                "f.lcp:4: expected the end of the file after the 1 entry of q, got an extra "
                "number 'nan'"}),
    [](const ::testing::TestParamInfo<BadCase>& param_info) { return param_info.param.name; });

TEST(LcpFileTest, SourceNamePrefixesErrors) {
  try {
    ParseLcp("x", "problems/a.lcp");
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()).rfind("problems/a.lcp:1: ", 0), 0u) << e.what();
  }
}

// A size within the cap but far larger than the file allocates nothing big: it is a
// "too few numbers" error.
TEST(LcpFileTest, LargeSizeInShortFileIsTooFew) {
  EXPECT_EQ(ParseError("100000\n1 2 3\n"),
            "f.lcp:2: expected 10000000000 entries of M and 100000 of q after n = 100000, got "
            "the end of the file after 3 numbers");
}

class TempDir {
 public:
  TempDir() {
    char tmpl[] = "/tmp/vinci_lcp_file_test_XXXXXX";
    const char* d = mkdtemp(tmpl);
    if (d == nullptr) throw std::runtime_error("mkdtemp failed");
    path_ = d;
  }
  ~TempDir() {
    for (const std::string& f : files_) std::remove(f.c_str());
    std::remove(path_.c_str());
  }
  std::string Write(const std::string& name, const std::string& text) {
    const std::string p = path_ + "/" + name;
    std::ofstream(p, std::ios::binary) << text;
    files_.push_back(p);
    return p;
  }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::vector<std::string> files_;
};

TEST(LcpFileTest, ReadsFileAndNamesItInErrors) {
  TempDir dir;
  const std::string good = dir.Write("good.lcp", "1\n2\n-4\n");
  const LcpProblem p = ReadLcpFile(good);
  EXPECT_EQ(p.M(0, 0), 2.0);
  EXPECT_EQ(p.q(0), -4.0);

  const std::string bad = dir.Write("bad.lcp", "1\n2\n-4 5\n");
  try {
    ReadLcpFile(bad);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), bad +
                                         ":3: expected the end of the file after the 1 entry "
                                         "of q, got an extra number '5'");
  }
}

TEST(LcpFileTest, UnreadableFilesThrowInvalidArgument) {
  TempDir dir;
  const std::string missing = dir.path() + "/no_such.lcp";
  try {
    ReadLcpFile(missing);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), missing + ": cannot open LCP file");
  }
  try {
    ReadLcpFile(dir.path());  // a directory
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), dir.path() + ": cannot read LCP file: it is a directory");
  }
  // An empty file is read (and then rejected by the parser, not as unreadable).
  const std::string empty = dir.Write("empty.lcp", "");
  try {
    ReadLcpFile(empty);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()),
              empty + ":1: " + kSizeExpected + "the end of the file (no numbers)");
  }
}

// WriteLcpFile → ParseLcp reproduces M and q bit for bit, including values whose shortest
// decimal form is long, subnormals, signed zeros and the extremes of double.
TEST(LcpFileTest, RoundTripIsBitExact) {
  std::mt19937 rng(20240611);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_int_distribution<int> e(-300, 300);
  const double special[] = {0.0,
                            -0.0,
                            1.0 / 3.0,
                            3.141592653589793,
                            0.1,
                            std::numeric_limits<double>::max(),
                            std::numeric_limits<double>::lowest(),
                            std::numeric_limits<double>::min(),
                            std::numeric_limits<double>::denorm_min(),
                            -std::numeric_limits<double>::denorm_min(),
                            9.8,
                            123456789012345680.0};
  for (int n : {1, 2, 3, 17}) {
    LcpProblem p;
    p.M.resize(n, n);
    p.q.resize(n);
    int k = 0;
    auto next = [&] {
      const int s = k++;
      if (s < static_cast<int>(std::size(special))) return special[s];
      return u(rng) * std::pow(10.0, e(rng));
    };
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < n; ++j) p.M(i, j) = next();
    }
    for (int i = 0; i < n; ++i) p.q(i) = next();
    std::ostringstream out;
    WriteLcpFile(p, out);
    SCOPED_TRACE(out.str());
    ExpectSameBits(ParseLcp(out.str(), "written"), p);
  }
}

TEST(LcpFileTest, WrittenFileIsRowByRowWithComments) {
  LcpProblem p;
  p.M.resize(2, 2);
  p.M << 1, 2, 3, 4.5;
  p.q = Eigen::Vector2d(-1, 0.25);
  std::ostringstream out;
  WriteLcpFile(p, out);
  EXPECT_EQ(out.str(),
            "# LCP: find z >= 0 with w = M z + q >= 0 and z'w = 0 (format: docs/lcp-format.md)\n"
            "# n\n2\n# M, one row per line\n1 2\n3 4.5\n# q\n-1 0.25\n");
}

TEST(LcpFileTest, WriteRejectsWhatTheReaderWouldReject) {
  std::ostringstream out;
  LcpProblem empty;
  EXPECT_THROW(WriteLcpFile(empty, out), std::invalid_argument);
  LcpProblem not_square{MatrixXd::Ones(2, 3), VectorXd::Ones(2)};
  EXPECT_THROW(WriteLcpFile(not_square, out), std::invalid_argument);
  LcpProblem mismatch{MatrixXd::Ones(2, 2), VectorXd::Ones(3)};
  EXPECT_THROW(WriteLcpFile(mismatch, out), std::invalid_argument);
  LcpProblem nan_m{MatrixXd::Ones(2, 2), VectorXd::Ones(2)};
  nan_m.M(1, 0) = std::numeric_limits<double>::quiet_NaN();
  try {
    WriteLcpFile(nan_m, out);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("non-finite entry in M"), std::string::npos) << e.what();
  }
  LcpProblem inf_q{MatrixXd::Ones(1, 1), VectorXd::Constant(1, -HUGE_VAL)};
  try {
    WriteLcpFile(inf_q, out);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("non-finite entry in q"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(out.str().empty()) << "nothing is written for a rejected problem";
}

TEST(LcpFileTest, ParsesVectors) {
  const VectorXd v = ParseLcpVector("# warm start\n0.5 0\n+2e-1 # last\n", 3);
  EXPECT_EQ(v, Eigen::Vector3d(0.5, 0.0, 0.2));
  EXPECT_EQ(VectorError("1 2", 3),
            "z.txt:1: expected 3 numbers, got the end of the file after 2 numbers");
  EXPECT_EQ(VectorError("", 1),
            "z.txt:1: expected 1 number, got the end of the file after 0 numbers");
  EXPECT_EQ(VectorError("1\n2\n3\n", 2),
            "z.txt:3: expected the end of the file after 2 numbers, got '3'");
  EXPECT_EQ(VectorError("1\n-2\n", 2),
            "z.txt:2: expected a finite number >= 0 for entry 2, got '-2'");
  EXPECT_EQ(VectorError("nan\n", 1),
            "z.txt:1: expected a finite number >= 0 for entry 1, got 'nan'");
  EXPECT_EQ(VectorError("1 x", 2), "z.txt:1: expected a finite number >= 0 for entry 2, got 'x'");
  EXPECT_THROW(ParseLcpVector("1", 0), std::invalid_argument);
}

// The bundled examples parse and Lemke reproduces the solutions documented in their comments.
TEST(LcpFileTest, BundledExamplesHaveTheirDocumentedSolutions) {
  struct Example {
    const char* file;
    std::vector<double> z;
    double tolerance;  // Lemke's pivoting error on these small, well-scaled problems
  };
  const double third = 1.0 / 3.0;
  const std::vector<Example> examples = {
      {"cycling.lcp", {third, third, third}, 1e-12},
      {"murty8.lcp", {1, 0, 0, 0, 0, 0, 0, 0}, 1e-12},
      {"box_sliding_2d.lcp",
       {0.0367875, 0.0613125, 0.01839375, 0, 0.03065625, 0, 0.45095, 0.45095},
       1e-12},
  };
  for (const Example& ex : examples) {
    SCOPED_TRACE(ex.file);
    const LcpProblem p = ReadLcpFile(ExamplePath(ex.file));
    ASSERT_EQ(p.size(), static_cast<int>(ex.z.size()));
    VectorXd z;
    const SolverReport r = LemkeSolver().Solve(p, nullptr, &z);
    ASSERT_TRUE(r.ok()) << r.message;
    EXPECT_LE(LcpResidual(p, z), 1e-12);
    for (int i = 0; i < p.size(); ++i) EXPECT_NEAR(z(i), ex.z[i], ex.tolerance) << "i = " << i;
  }
}

}  // namespace
}  // namespace vinci::sim
