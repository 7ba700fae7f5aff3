// Dialect tables: names, syntax flags and what each G code means where the controls disagree.
#include <gtest/gtest.h>

#include "support.hpp"

namespace {

using namespace pptest;
using gc::GGroup;
using gc::GMeaning;

std::uint16_t c10(double g) { return static_cast<std::uint16_t>(g * 10 + 0.5); }

GMeaning meaning(const gc::Dialect& d, double g) {
  const gc::GCodeDef* def = d.find_g(c10(g));
  return def ? def->meaning : GMeaning::unknown;
}

TEST(Dialect, NamesRoundTrip) {
  EXPECT_EQ(gc::dialect_names(), "fanuc|siemens|linuxcnc|heidenhain-iso|heidenhain");
  for (const char* name : {"fanuc", "siemens", "linuxcnc", "heidenhain-iso", "heidenhain"}) {
    const auto d = gc::make_dialect(name);
    ASSERT_TRUE(d.has_value()) << name;
    EXPECT_EQ(d->name, name);
    EXPECT_EQ(gc::make_dialect(d->id).name, name);
  }
  EXPECT_FALSE(gc::make_dialect("klartext").has_value());
  EXPECT_FALSE(gc::make_dialect("Fanuc").has_value());
  EXPECT_FALSE(gc::make_dialect("").has_value());
}

TEST(Dialect, SyntaxFlags) {
  const auto f = dialect("fanuc"), s = dialect("siemens"), l = dialect("linuxcnc"), h = dialect("heidenhain-iso");
  EXPECT_TRUE(f.paren_comments);
  EXPECT_FALSE(f.semicolon_comments);
  EXPECT_TRUE(f.hash_parameters);
  EXPECT_FALSE(s.paren_comments);
  EXPECT_TRUE(s.semicolon_comments);
  EXPECT_TRUE(s.multi_letter_identifiers);
  EXPECT_TRUE(s.r_parameters);
  EXPECT_FALSE(s.hash_parameters);
  EXPECT_TRUE(l.paren_comments);
  EXPECT_TRUE(l.semicolon_comments);
  EXPECT_TRUE(l.o_word_control);
  EXPECT_TRUE(l.spaces_inside_words);
  EXPECT_EQ(l.assignment_timing, gc::AssignmentTiming::end_of_line);
  EXPECT_TRUE(h.star_block_end);
  EXPECT_TRUE(h.semicolon_comments);
  EXPECT_FALSE(h.hash_parameters);
  EXPECT_EQ(f.diameter_axis, 0);
  EXPECT_EQ(dialect("fanuc", true).diameter_axis, 'X');
  EXPECT_TRUE(dialect("fanuc", true).lathe);
}

TEST(Dialect, CommonMotionCodes) {
  for (const char* name : {"fanuc", "siemens", "linuxcnc", "heidenhain-iso"}) {
    const auto d = dialect(name);
    EXPECT_EQ(meaning(d, 0), GMeaning::rapid) << name;
    EXPECT_EQ(meaning(d, 1), GMeaning::linear) << name;
    EXPECT_EQ(meaning(d, 2), GMeaning::arc_cw) << name;
    EXPECT_EQ(meaning(d, 3), GMeaning::arc_ccw) << name;
    EXPECT_EQ(meaning(d, 17), GMeaning::plane_xy) << name;
    EXPECT_EQ(meaning(d, 18), GMeaning::plane_zx) << name;
    EXPECT_EQ(meaning(d, 19), GMeaning::plane_yz) << name;
    EXPECT_EQ(meaning(d, 90), GMeaning::absolute) << name;
    EXPECT_EQ(meaning(d, 54), GMeaning::work_offset) << name;
    EXPECT_EQ(d.find_g(c10(0))->group, GGroup::motion);
    EXPECT_EQ(d.find_g(c10(17))->group, GGroup::plane);
    EXPECT_EQ(meaning(d, 1.5), GMeaning::unknown) << name;
    EXPECT_EQ(d.find_g(60000), nullptr);
  }
}

TEST(Dialect, UnitsDifferBetweenFamilies) {
  EXPECT_EQ(meaning(dialect("fanuc"), 20), GMeaning::inch);
  EXPECT_EQ(meaning(dialect("fanuc"), 21), GMeaning::mm);
  EXPECT_EQ(meaning(dialect("linuxcnc"), 20), GMeaning::inch);
  EXPECT_EQ(meaning(dialect("siemens"), 70), GMeaning::inch);
  EXPECT_EQ(meaning(dialect("siemens"), 71), GMeaning::mm);
  EXPECT_EQ(meaning(dialect("siemens"), 700), GMeaning::inch);
  EXPECT_EQ(meaning(dialect("heidenhain-iso"), 70), GMeaning::inch);
  EXPECT_EQ(meaning(dialect("heidenhain-iso"), 71), GMeaning::mm);
  EXPECT_EQ(meaning(dialect("fanuc"), 70), GMeaning::unknown);  // G70 is a lathe cycle only with --lathe
}

TEST(Dialect, FiveAxisCodes) {
  const auto f = dialect("fanuc");
  EXPECT_EQ(meaning(f, 43.4), GMeaning::tcp_on);
  EXPECT_EQ(meaning(f, 43.5), GMeaning::tcp_vector_on);
  EXPECT_EQ(meaning(f, 68.2), GMeaning::tilted_plane_on);
  EXPECT_EQ(meaning(f, 54.1), GMeaning::work_offset);
  EXPECT_EQ(meaning(f, 12.1), GMeaning::polar_interp_on);
  EXPECT_EQ(meaning(f, 112), GMeaning::polar_interp_on);
  EXPECT_EQ(f.find_g(c10(43.4))->group, f.find_g(c10(49))->group);  // G43.4 and G49 exclude each other
  const auto l = dialect("linuxcnc");
  EXPECT_EQ(meaning(l, 43.4), GMeaning::unknown);
  EXPECT_EQ(meaning(l, 54.1), GMeaning::unknown);
  EXPECT_EQ(meaning(l, 59.1), GMeaning::work_offset);
  EXPECT_EQ(meaning(l, 5.1), GMeaning::spline);
  EXPECT_EQ(meaning(l, 7), GMeaning::diameter_mode);
  EXPECT_EQ(meaning(l, 8), GMeaning::radius_mode);
  EXPECT_EQ(meaning(l, 71), GMeaning::turning_cycle);
  EXPECT_EQ(meaning(l, 76), GMeaning::threading);
  EXPECT_EQ(meaning(l, 92.1), GMeaning::reset_position_offset);
  const auto h = dialect("heidenhain-iso");
  EXPECT_EQ(meaning(h, 93), GMeaning::datum_shift_heidenhain);  // not inverse time here
  EXPECT_EQ(meaning(h, 7), GMeaning::tilted_plane_heidenhain);
  EXPECT_EQ(meaning(h, 74), GMeaning::machine_move_heidenhain);
  EXPECT_EQ(meaning(dialect("fanuc"), 93), GMeaning::feed_inverse_time);
  EXPECT_EQ(meaning(dialect("siemens"), 153), GMeaning::machine_coords);
}

TEST(Dialect, FanucLatheSystemA) {
  const auto m = dialect("fanuc"), t = dialect("fanuc", true);
  EXPECT_EQ(meaning(m, 98), GMeaning::return_initial);
  EXPECT_EQ(meaning(t, 98), GMeaning::feed_per_minute);
  EXPECT_EQ(meaning(t, 99), GMeaning::feed_per_rev);
  EXPECT_EQ(meaning(m, 76), GMeaning::drill_cycle);
  EXPECT_EQ(meaning(t, 76), GMeaning::threading);
  EXPECT_EQ(meaning(t, 71), GMeaning::turning_cycle);
  EXPECT_EQ(meaning(t, 90), GMeaning::turning_cycle);
  EXPECT_EQ(meaning(t, 91), GMeaning::unknown);  // system A: incremental is U/W
  EXPECT_EQ(meaning(t, 50), GMeaning::spindle_clamp);
  EXPECT_EQ(t.gcode_system, 'A');
}

TEST(Dialect, FanucLatheSystemB) {
  gc::DialectOptions o;
  o.lathe = true;
  o.gcode_system = 'B';
  const auto b = gc::make_dialect(gc::DialectId::fanuc, o);
  EXPECT_EQ(b.gcode_system, 'B');
  EXPECT_EQ(meaning(b, 90), GMeaning::absolute);
  EXPECT_EQ(meaning(b, 91), GMeaning::incremental);
  EXPECT_EQ(meaning(b, 94), GMeaning::feed_per_minute);
  EXPECT_EQ(meaning(b, 95), GMeaning::feed_per_rev);
  EXPECT_EQ(meaning(b, 98), GMeaning::return_initial);
  EXPECT_EQ(meaning(b, 77), GMeaning::turning_cycle);
  EXPECT_EQ(meaning(b, 71), GMeaning::turning_cycle);
  EXPECT_EQ(meaning(b, 92), GMeaning::spindle_clamp);
}

TEST(Dialect, ExplicitDiameterAxisOption) {
  gc::DialectOptions o;
  o.diameter_axis = 'X';
  EXPECT_EQ(gc::make_dialect(gc::DialectId::linuxcnc, o).diameter_axis, 'X');
}

}  // namespace
