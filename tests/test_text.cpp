// Text for messages (io/text.hpp): escaping what a file or a user typed, and did-you-mean.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "kanedyn/io/text.hpp"

namespace {

using kanedyn::io::closest_word;
using kanedyn::io::edit_distance;
using kanedyn::io::printable;

TEST(Text, PrintableEscapesEveryControlAndKeepsUtf8) {
  EXPECT_EQ(printable("plain words"), "plain words");
  EXPECT_EQ(printable(std::string("a\nb\rc\td\x1b[31m\x7f", 13)), "a\\nb\\rc\\td\\x1b[31m\\x7f");
  EXPECT_EQ(printable(std::string("nul\0here", 8)), "nul\\x00here");
  EXPECT_EQ(printable("r\xc3\xa9sum\xc3\xa9"), "r\xc3\xa9sum\xc3\xa9");  // UTF-8 stays
  EXPECT_EQ(printable("c1 \xc2\x9b end"), "c1 \\u009b end");             // C1 CSI
  EXPECT_EQ(printable("line\xe2\x80\xa8sep"), "line\\u2028sep");
  EXPECT_EQ(printable("bad \xff byte"), "bad \\xff byte");
  EXPECT_EQ(printable("cut \xc3"), "cut \\xc3");  // a truncated sequence is not UTF-8
}

TEST(Text, PrintableCutsAtACharacterBoundary) {
  EXPECT_EQ(printable("abcdef", 3), "abc...");
  EXPECT_EQ(printable("ab\xc3\xa9", 3), "ab...");  // the 2-byte character does not fit
  EXPECT_EQ(printable("abc", 3), "abc");
  EXPECT_EQ(printable(std::string(1000, 'x'), 0).size(), 1000u);
}

TEST(Text, ClosestWordWithinTwoEdits) {
  EXPECT_EQ(edit_distance("simulat", "simulate"), 1u);
  EXPECT_EQ(edit_distance("", "abc"), 3u);
  EXPECT_EQ(edit_distance("kitten", "sitting"), 3u);
  const std::vector<std::string> commands{"info", "eom", "simulate", "bench"};
  EXPECT_EQ(closest_word("simulat", commands), "simulate");
  EXPECT_EQ(closest_word("bnech", commands), "bench");
  EXPECT_EQ(closest_word("frobnicate", commands), "");
  EXPECT_EQ(closest_word("--tend", {"--t-end", "--dt-out"}), "--t-end");
}

}  // namespace
