// tools/chasles-spy on a virtual display: the plant and the controller run, lcm-spy (through our
// launcher, with the chasles types jar) listens, and the test reads the screen with OCR until the
// channel table shows our channels with their chasles type names; then it opens CHASLES_STATUS,
// as a user would with a double click, and reads the decoded fields. Everything runs in this test
// binary's own network namespace (tools/netns.sh launches it), the X server included: it listens
// only on an abstract socket, which belongs to the namespace, so parallel tests never meet.
// The final screenshot is kept in tests/artifacts/chasles-spy.png under the build tree.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <chasles/controller_status_t.hpp>
#include <cmath>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "support/process.hpp"
#include "support/bus_listener.hpp"
#include "support/reference.hpp"

namespace chasles::testing {
namespace {

using Clock = std::chrono::steady_clock;
constexpr char kTip[] = "panda_hand";
constexpr int kOcrScale = 3;  // lcm-spy's 12-pixel font is too small for tesseract as it is

// Letters and digits only, lower case: OCR reads "CHASLES_STATUS" as "CHASLES STATUS" and
// "controller_status_t" as "controller status t", so both sides are compared this way.
std::string normalised(const std::string& text) {
  std::string out;
  for (const char c : text) {
    if (std::isalnum(static_cast<unsigned char>(c))) out += char(std::tolower(static_cast<unsigned char>(c)));
  }
  return out;
}

class Display {
 public:
  Display() : name_(":" + std::to_string(10 + ::getpid() % 500)), env_{"DISPLAY=" + name_} {}

  const std::string& name() const { return name_; }

  RunResult run(const std::vector<std::string>& argv) const { return run_to_completion(argv, "/dev/null", env_); }

  /// A screenshot of the whole screen to `path`.
  bool screenshot(const std::string& path) const {
    return run({IMPORT, "-display", name_, "-window", "root", path}).exit_code == 0;
  }

  /// The words tesseract reads in the `region` ("WxH+X+Y") of the screenshot at `path`, with their
  /// positions in screen pixels.
  struct Word {
    std::string text;
    int x, y, width, height;
  };
  std::vector<Word> read_words(const std::string& path, const std::string& region) const {
    const std::string big = path + ".ocr.png";
    // Only the region, grey, enlarged and thresholded: black text on white, as tesseract reads best.
    run({CONVERT, path, "-crop", region, "+repage", "-colorspace", "Gray", "-resize", std::to_string(kOcrScale * 100) + "%",
         "-threshold", "60%", big});
    const RunResult r = run({TESSERACT, big, "-", "--psm", "11", "tsv"});
    std::remove(big.c_str());
    std::vector<Word> words;
    std::istringstream lines(r.out);
    std::string line;
    while (std::getline(lines, line)) {
      // level page block par line word left top width height conf text
      std::vector<std::string> cells;
      std::istringstream fields(line);
      std::string cell;
      while (std::getline(fields, cell, '\t')) cells.push_back(cell);
      if (cells.size() < 12 || cells[0] != "5" || normalised(cells[11]).empty()) continue;
      int left = 0, top = 0;
      std::sscanf(region.c_str(), "%*dx%*d+%d+%d", &left, &top);
      words.push_back({cells[11], left + std::atoi(cells[6].c_str()) / kOcrScale,
                       top + std::atoi(cells[7].c_str()) / kOcrScale,
                       std::atoi(cells[8].c_str()) / kOcrScale, std::atoi(cells[9].c_str()) / kOcrScale});
    }
    return words;
  }

  /// The number tesseract reads in the cell `region` of the screenshot at `path` ("" if none).
  std::string read_number(const std::string& path, const std::string& region) const {
    const std::string big = path + ".cell.png";
    // A white border round the cell: tesseract misreads glyphs that touch the image's edge.
    run({CONVERT, path, "-crop", region, "+repage", "-colorspace", "Gray", "-resize", "400%", "-threshold", "60%",
         "-bordercolor", "white", "-border", "30", big});
    const RunResult r = run({TESSERACT, big, "-", "--psm", "7", "-c", "tessedit_char_whitelist=0123456789"});
    std::remove(big.c_str());
    return normalised(r.out);
  }

 private:
  std::string name_;
  std::vector<std::string> env_;
};

std::string joined(const std::vector<Display::Word>& words) {
  std::string text;
  for (const auto& w : words) text += normalised(w.text);
  return text;
}

// Screenshots and OCR until every one of `needles` is on screen, or `seconds` pass.
bool wait_for_text(const Display& display, const std::string& shot, const std::string& region,
                   const std::vector<std::string>& needles, double seconds, std::vector<Display::Word>& words) {
  const auto deadline = Clock::now() + std::chrono::duration<double>(seconds);
  do {
    if (display.screenshot(shot)) {
      words = display.read_words(shot, region);
      const std::string text = joined(words);
      if (std::all_of(needles.begin(), needles.end(),
                      [&](const std::string& n) { return text.find(normalised(n)) != std::string::npos; })) {
        return true;
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
  } while (Clock::now() < deadline);
  return false;
}

// Where each channel's row is on screen: the centre of its name, read by OCR as one word
// ("CHASLES_STATUS") or two ("CHASLES" "STATUS"), at times with the table's left border read as
// an "I" before it.
struct Row {
  int x = -1, y = -1;
};
Row find_row(const std::vector<Display::Word>& words, const std::string& suffix) {
  for (size_t i = 0; i < words.size(); ++i) {
    const std::string w = normalised(words[i].text);
    const std::string name = "chasles" + suffix;
    const bool one = w == name || w == "i" + name;
    const bool two = (w == "chasles" || w == "ichasles") && i + 1 < words.size() && normalised(words[i + 1].text) == suffix;
    if (one || two) return {words[i].x + words[i].width / 2, words[i].y + words[i].height / 2};
  }
  return {};
}

// The header word of lcm-spy's "Undecodable" column (its left edge, its width).
const Display::Word* undecodable_header(const std::vector<Display::Word>& words) {
  for (const auto& w : words) {
    if (normalised(w.text) == "undecodable") return &w;
  }
  return nullptr;
}

TEST(spy, ShowsTheChaslesChannelsDecoded) {
  for (const char* tool : {XVFB, JAVA, IMPORT, CONVERT, TESSERACT, XDOTOOL}) {
    if (std::string(tool).empty() || ::access(tool, X_OK) != 0) {
      GTEST_SKIP() << "needs Xvfb, java, ImageMagick, tesseract and xdotool (tools/deps.sh installs them: "
                      "chasles_packages_monitor); missing: "
                   << tool;
    }
  }
  Display display;
  ChildProcess xvfb({XVFB, display.name(), "-screen", "0", "1024x768x24", "-nolisten", "tcp", "-nolisten", "unix",
                     "-nolock"});
  const auto ready_by = Clock::now() + std::chrono::seconds(10);
  while (display.run({XDOTOOL, "getdisplaygeometry"}).exit_code != 0) {
    ASSERT_TRUE(xvfb.running() && Clock::now() < ready_by) << "Xvfb did not start:\n" << xvfb.stderr_text();
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }

  const std::vector<std::string> model{"--robot", data_path("panda.urdf"), "--tip", kTip, "--lcm-url", kLcmUrl};
  ChildProcess plant(concat({CHASLES_PLANT, "--q0", "0.2,0.3,0,-1.5,0,1.7,0.4", "--damping", "0.5"}, model));
  // Java and OCR share two cores with the 1 kHz loop here: a late state is no fault in this test.
  ChildProcess controller(concat({CHASLES_CONTROLLER, "--damping", "0.5", "--stale-ms", "100"}, model));
  ::setenv("DISPLAY", display.name().c_str(), 1);  // for the child processes started from here
  ChildProcess spy({CHASLES_SPY, "--lcm-url", kLcmUrl, "--types-jar", CHASLES_TYPES_JAR});

  // The channel table, each channel with its type: chasles-spy found our jar.
  const std::string shot = temp_path("screen.png");
  std::vector<Display::Word> words;
  // lcm-spy's table is at the top left of the screen.
  const bool table = wait_for_text(display, shot, "800x120+0+0",
                                   {"CHASLES_COMMAND", "joint_torque_command_t", "CHASLES_STATE", "robot_state_t",
                                    "CHASLES_STATUS", "controller_status_t"},
                                   20.0, words);
  ASSERT_TRUE(table) << "the channels did not appear with their types; on screen: " << joined(words)
                     << "\nchasles-spy's stderr:\n"
                     << spy.stderr_text() << "\n(see " << shot << ")";

  // The table shrinks to the top of the screen, so that the decoded message has room below it, and
  // spans the screen's width, its last column (Undecodable) at the right.
  display.run({XDOTOOL, "search", "--name", "^LCM Spy$", "windowsize", "%@", "1024", "112"});
  const std::vector<std::string> channels{"command", "state", "status"};
  ASSERT_TRUE(wait_for_text(display, shot, "800x80+0+0",
                            {"Undecodable", "CHASLES_COMMAND", "CHASLES_STATE", "CHASLES_STATUS"}, 10.0, words))
      << joined(words);
  const Display::Word* header = undecodable_header(words);
  ASSERT_NE(header, nullptr) << joined(words);
  // Every message lcm-spy received on every channel decoded with our types. Read before a viewer
  // opens: Debian's lcm-spy 1.3.1 also counts as undecodable a message whose decoding succeeded
  // but which reached a viewer window still being built (a NullPointerException in
  // ObjectPanel.setObject, which its catch block counts with the decoding errors; fixed upstream).
  for (const auto& channel : channels) {
    const Row row = find_row(words, channel);
    ASSERT_GE(row.y, 0) << "CHASLES_" << channel << " not located on screen: " << joined(words);
    // The cell: from just left of the header word (the column's values are left-aligned under
    // it) to past its end, one row high.
    const std::string cell = std::to_string(header->width + 16) + "x16+" + std::to_string(header->x - 10) + "+" +
                             std::to_string(row.y - 8);
    EXPECT_EQ(display.read_number(shot, cell), "0") << "CHASLES_" << channel << ": Undecodable (cell " << cell
                                                     << " of " << shot << ")";
  }

  // Open CHASLES_STATUS as a user does, with a double click on its row; the click is repeated if
  // its window does not appear.
  const Row status_row = find_row(words, "status");
  const auto opened_by = Clock::now() + std::chrono::seconds(10);
  bool decoded = false;
  while (!decoded && Clock::now() < opened_by) {
    display.run({XDOTOOL, "mousemove", std::to_string(status_row.x), std::to_string(status_row.y), "click",
                 "--repeat", "2", "--delay", "80", "1"});
    const auto window_by = Clock::now() + std::chrono::seconds(2);
    while (!decoded && Clock::now() < window_by) {
      decoded = display.run({XDOTOOL, "search", "--name", "^CHASLES_STATUS$", "windowmove", "%@", "0", "116",
                             "windowsize", "%@", "1024", "652"})
                    .exit_code == 0;
    }
  }
  ASSERT_TRUE(decoded) << "no window for CHASLES_STATUS after double clicks at " << status_row.x << ","
                       << status_row.y;

  // A joint move, so that lcm-spy's little plots beside the values have something to draw.
  StatusListener listener(kLcmUrl);
  ASSERT_TRUE(listener.wait_for(controller_status_t::HOLDING, 10.0));
  const RunResult target = run_to_completion(concat(
      {CHASLES_CLI, "target", "--joint", "0.6,0.1,0.2,-1.2,0.1,1.4,0.8", "--duration", "1.2"}, model));
  EXPECT_EQ(target.exit_code, 0) << target.err;
  EXPECT_TRUE(listener.wait_for(controller_status_t::RUNNING, 5.0));

  // The message, field by field, under its type name. lcm-spy may lay its window out again when the
  // first messages fill it, undoing the size given above: give it again.
  display.run({XDOTOOL, "search", "--name", "^CHASLES_STATUS$", "windowmove", "%@", "0", "116", "windowsize", "%@",
               "1024", "652"});
  const bool fields = wait_for_text(display, shot, "700x440+0+116",
                                    {"controller_status_t", "utime", "num_joints", "q_desired[6]", "tracking_error[0]"},
                                    15.0, words);
  EXPECT_TRUE(fields) << "the decoded fields did not appear; on screen: " << joined(words);

  // The picture kept is taken once the move is over, its curves drawn beside the values.
  EXPECT_TRUE(listener.wait_for(controller_status_t::HOLDING, 5.0));
  EXPECT_TRUE(display.screenshot(shot));
  const std::string kept = std::string(CHASLES_ARTIFACTS) + "/chasles-spy.png";
  ::mkdir(CHASLES_ARTIFACTS, 0777);
  std::ofstream(kept, std::ios::binary) << read_file(shot);
  std::remove(shot.c_str());
  std::printf("screenshot: %s\n", kept.c_str());

  spy.stop(SIGTERM);
  controller.stop(SIGTERM);
  plant.stop(SIGTERM);
  xvfb.stop(SIGTERM);
}

}  // namespace
}  // namespace chasles::testing
