// Inputs that are not files someone wrote, or that the process has no room for: a tool answers at once
// in one line naming the file, exit status 1, instead of waiting forever (a FIFO), overflowing its
// stack (JSON nested 600,000 deep) or saying "out of memory" with no file named (an address-space limit).
#include <sys/stat.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <utility>
#include <vector>

#include "run_tool.hpp"
#include "temp_dir.hpp"

namespace fs = std::filesystem;

namespace {

using smseg::test::Outcome;
using smseg::test::run;
using smseg::test::tool;

// Address-space limits mean nothing to a sanitized build (its shadow memory alone passes them).
#if defined(__SANITIZE_ADDRESS__)
constexpr bool kSanitized = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr bool kSanitized = true;
#else
constexpr bool kSanitized = false;
#endif
#else
constexpr bool kSanitized = false;
#endif

}  // namespace

TEST(HostileFiles, AFifoNamedAsAManifestIsRefusedAtOnce) {
  const fs::path dir = smseg::test::temp_dir("hostile-fifo");
  const fs::path manifest = dir / "sequence.json";
  ASSERT_EQ(::mkfifo(manifest.c_str(), 0600), 0);
  // (Before: the tool waited for a writer that never came; `timeout` ends it with status 124.)
  const Outcome r = run("timeout 20 " + tool("check-sequence") + " " + dir.string());
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_EQ(r.out, "check-sequence: error: " + manifest.string() + ": is a FIFO (named pipe), expected a regular file\n");
  fs::remove_all(dir);
}

TEST(HostileFiles, JsonNestedTooDeeplyIsOneLineNotACrash) {
  const fs::path dir = smseg::test::temp_dir("hostile-depth");
  Outcome r = run(tool("make-sequence") + " --scene corridor --frames 2 --size 64x48 -q -o " + (dir / "seq").string());
  ASSERT_EQ(r.status, 0) << r.out;
  // The sequence's free-form "extra" holds 600,000 nested arrays (a 1.2 MB file). (Before: the reader
  // took it and copied it by recursion, and the tool died of a stack overflow, status 139.)
  const fs::path manifest = dir / "seq" / "sequence.json";
  std::string text;
  {
    std::ifstream in(manifest);
    text.assign(std::istreambuf_iterator<char>(in), {});
  }
  const std::size_t last_brace = text.rfind('}');
  ASSERT_NE(last_brace, std::string::npos);
  text = text.substr(0, last_brace) + ", \"extra\": " + std::string(600000, '[') + std::string(600000, ']') + "}\n";
  std::ofstream(manifest) << text;
  r = run(tool("check-sequence") + " " + (dir / "seq").string());
  EXPECT_EQ(r.status, 1) << r.out.substr(0, 300);
  EXPECT_EQ(r.out.rfind("check-sequence: error: " + manifest.string() +
                            ": nested deeper than 256 levels of arrays and objects at line ",
                        0),
            0u)
      << r.out.substr(0, 300);
  EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out.substr(0, 300);
  fs::remove_all(dir);
}

TEST(HostileFiles, AFileTheProcessHasNoRoomForIsNamedBeforeItIsRead) {
  if (kSanitized) GTEST_SKIP() << "address-space limits do not apply to a sanitized build";
  const fs::path dir = smseg::test::temp_dir("hostile-room");
  // A forest part within the 4 GiB limit of forest files, in a process limited to about 1 GB of address
  // space: the file is 1.5 GiB (sparse), so reading it cannot start. (Before: "out of memory", no file.)
  const fs::path sparse = dir / "part.json";
  { std::ofstream(sparse) << "{"; }
  fs::resize_file(sparse, 1536 * (std::uintmax_t{1} << 20));
  const std::string limited = "ulimit -v 1000000 && " + tool("train-forest") + " --merge ";
  Outcome r = run(limited + sparse.string() + " -o " + (dir / "forest.json").string());
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_EQ(r.out.rfind("train-forest: error: " + sparse.string() +
                            ": is 1536 MiB; reading it needs about 1536 MiB of memory, and this process may take only ",
                        0),
            0u)
      << r.out;
  EXPECT_NE(r.out.find("(its address-space limit, ulimit -v)\n"), std::string::npos) << r.out;
  // A 96 MiB part that fits, but whose 50 million numbers would parse into 800 MiB and more.
  const fs::path numbers = dir / "numbers.json";
  {
    std::ofstream out(numbers);
    std::string block;
    for (int i = 0; i < 1 << 20; ++i) block += ",0";
    out << "[0";
    for (int i = 0; i < 48; ++i) out << block;
    out << "]";
  }
  r = run(limited + numbers.string() + " -o " + (dir / "forest.json").string());
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_EQ(r.out.rfind("train-forest: error: " + numbers.string() + ": is 96 MiB of JSON; parsing it would take more than the ", 0),
            0u)
      << r.out;
  EXPECT_FALSE(fs::exists(dir / "forest.json"));
  fs::remove_all(dir);
}

// A work folder given with another sequence than the one it was made from: the tools that read its
// tracks beside a sequence say so in one line naming tracks.json. (Before: eval-stereo-path scored the
// other sequence's ground truth against these tracks, and segment-cloud's saliency seeds projected
// them into the other sequence's images.)
TEST(HostileFiles, AWorkFolderOfAnotherSequenceIsRefused) {
  const fs::path dir = smseg::test::temp_dir("hostile-other-sequence");
  const std::string seq1 = (dir / "corridor").string(), seq2 = (dir / "lab").string(), work = (dir / "work").string();
  Outcome r = run(tool("make-sequence") + " --scene corridor --frames 12 --size 96x72 -q -o " + seq1);
  ASSERT_EQ(r.status, 0) << r.out;
  r = run(tool("make-sequence") + " --scene lab --seed 2 --frames 12 --size 96x72 -q -o " + seq2);
  ASSERT_EQ(r.status, 0) << r.out;
  r = run(tool("extract-features") + " -q " + seq1 + " -o " + work);
  ASSERT_EQ(r.status, 0) << r.out;
  const std::string tracks = (dir / "work" / "tracks.json").string();
  ASSERT_EQ(run(tool("eval-stereo-path") + " " + seq1 + " " + work).status, 0);
  for (const std::string& command :
       {tool("eval-stereo-path") + " " + seq2 + " " + work,
        tool("segment-cloud") + " --method mrf --seeds saliency --sequence " + seq2 + " --work " + work +
            " --frame 3 -o " + (dir / "out.pcd").string()}) {
    r = run(command);
    EXPECT_EQ(r.status, 1) << command << "\n" << r.out;
    EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
    EXPECT_NE(r.out.find(tracks + ": sequence: is for sequence \"synth-corridor-seed1\", not \"synth-lab-seed2\""),
              std::string::npos)
        << command << "\n" << r.out;
  }
  fs::remove_all(dir);
}

// Damaged stack files of a real extraction (version 2 values files, with the colour image of
// --appearance): train-forest refuses each in one line naming the file, exit status 1, before it
// allocates from what the file says (a packed size of 2^63 bytes, a header for another image size).
TEST(HostileFiles, DamagedStackValuesFilesAreRefusedInOneLine) {
  const fs::path dir = smseg::test::temp_dir("hostile-values");
  const std::string seq = (dir / "corridor").string(), work = (dir / "work").string();
  Outcome r = run(tool("make-sequence") + " --scene corridor --frames 8 --size 96x72 -q -o " + seq);
  ASSERT_EQ(r.status, 0) << r.out;
  r = run(tool("extract-features") + " -q --appearance " + seq + " -o " + work);
  ASSERT_EQ(r.status, 0) << r.out;
  const fs::path file = dir / "work" / "stacks" / "000000.values.bin";  // the labelled frame training reads
  std::string good;
  {
    std::ifstream in(file, std::ios::binary);
    good.assign(std::istreambuf_iterator<char>(in), {});
  }
  ASSERT_GT(good.size(), 64u);
  std::string huge = good, wide = good, garbage = good;
  for (int b = 0; b < 8; ++b) huge[24 + 8 + b] = b == 7 ? '\x7f' : '\xff';  // the first block's packed size
  wide[12] = '\x61';                                                       // width 96 + 1
  for (std::size_t i = 40; i < garbage.size(); i += 3) garbage[i] = static_cast<char>(i * 7);
  const std::vector<std::pair<std::string, std::string>> cases = {
      {good.substr(0, good.size() / 2), "the file ends before (truncated?)"},
      {huge, "the file ends before (truncated?)"},
      {wide, "holds 97x72 images, the work folder's stacks.json says 96x72"},
      {garbage, "damaged file"},
      {"", "is not a stack values file"}};
  for (const auto& [bytes, reason] : cases) {
    { std::ofstream(file, std::ios::binary | std::ios::trunc) << bytes; }
    r = run(tool("train-forest") + " " + work + " -M 1 -K 5 -q -o " + (dir / "forest.json").string());
    EXPECT_EQ(r.status, 1) << r.out;
    EXPECT_EQ(std::count(r.out.begin(), r.out.end(), '\n'), 1) << r.out;
    EXPECT_EQ(r.out.rfind("train-forest: error: " + file.string() + ": ", 0), 0u) << r.out;
    EXPECT_NE(r.out.find(reason), std::string::npos) << reason << "\n" << r.out;
  }
  fs::remove_all(dir);
}
