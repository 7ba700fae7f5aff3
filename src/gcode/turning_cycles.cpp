// LinuxCNC lathe profile cycles G70, G71, G72 (and G7x.1 / G7x.2): the tool path rs274 cuts.
//
// The path is worked out on a normalised copy of the profile: turned by 90° for facing (G72, or
// a G70 profile that does not run monotonically along Z) and mirrored so that the profile runs
// towards -Z and +X; the moves are mapped back on output. Roughing cuts layers at X levels that
// step by the increment I from the start point, each cut ending on the profile (offset by D)
// and retracting by R at 45°; where the profile climbs back into a pocket, the pocket is cut the
// same way from its start. G70 follows the offset profile, once per pass.
#include "src/gcode/turning_cycles.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <deque>
#include <iterator>
#include <list>

namespace postproc::gcode::turning {
namespace {

constexpr Point kI{0, 1};
constexpr double kTol = 1e-6;  ///< rs274's tolerance in the roughing steps

struct Failure {
  std::string what;
};

double size_of(const Segment& s) {
  return s.arc ? std::min(std::abs(s.a - s.b), std::abs(s.a - s.c)) : std::abs(s.a - s.b);
}

/// Runs towards -Z and never turns back (arcs: stay on the side of their centre they start on).
bool monotonic(const Segment& s) {
  if (!s.arc) return (s.b - s.a).real() <= 1e-3;
  if (s.corner != 0) return true;  // a fillet not yet made
  const double entry = (s.a - s.c).imag(), exit = (s.b - s.c).imag(), dz = (s.b - s.a).real();
  if (s.ccw) return entry >= -1e-3 && exit >= -1e-3 && dz <= -1e-3;
  return entry <= 1e-3 && exit <= 1e-3 && dz <= -1e-3;
}

void shift_normal(Segment& s, double dist) {
  if (!s.arc) {
    const Point d = kI * dist * (s.a - s.b) / std::abs(s.a - s.b);
    s.a += d;
    s.b += d;
    return;
  }
  const double r = std::abs(s.a - s.c);
  const double k = (r + (s.ccw ? 1.0 : -1.0) * dist) / r;
  s.a = k * (s.a - s.c) + s.c;
  s.b = k * (s.b - s.c) + s.c;
}

bool on_arc(const Segment& s, Point p) {
  const double from_start = (std::conj(s.a - s.c) * (p - s.c)).imag();
  const double to_end = (std::conj(s.b - s.c) * (p - s.c)).imag();
  if (s.ccw) return from_start >= -1e-6 && to_end <= 1e-6;
  return from_start <= 1e-6 && to_end >= -1e-6;
}

/// Z values where the segment meets the level X = x.
void crossings(const Segment& s, double x, std::deque<double>& zs) {
  if (!s.arc) {
    if (std::min(s.a.imag(), s.b.imag()) > x + 1e-6 || std::max(s.a.imag(), s.b.imag()) < x - 1e-6) return;
    if (std::abs((s.a - s.b).imag()) < 1e-6) {
      zs.push_back(s.a.real());
      zs.push_back(s.b.real());
    } else {
      zs.push_back((x - s.a.imag()) / (s.b.imag() - s.a.imag()) * (s.b.real() - s.a.real()) + s.a.real());
    }
    return;
  }
  const double r = std::abs(s.a - s.c);
  double q = -(x - r - s.c.imag()) * (x + r - s.c.imag());
  if (q < -1e-6) return;
  q = std::sqrt(std::max(q, 0.0));
  const Point p1(s.c.real() + q, x), p2(s.c.real() - q, x);
  if (on_arc(s, p1)) zs.push_back(p1.real());
  if (on_arc(s, p2)) zs.push_back(p2.real());
}

/// Moves the end of `prev` and the start of `next` to where the two (offset) elements meet.
void join(Segment& prev, Segment& next) {
  if (!next.arc && !prev.arc) {
    const Point rot = std::conj(next.a - next.b) / std::abs(next.a - next.b);
    const Point ps = (prev.a - next.b) * rot, pe = (prev.b - next.b) * rot;
    if ((ps - pe).imag() == 0) throw Failure{"Cannot intersect parallel lines"};
    const double f = ps.imag() / (ps - pe).imag();
    next.a = prev.b = (ps + f * (pe - ps)) / rot + next.b;
    return;
  }
  if (!next.arc || !prev.arc) {
    if (std::abs(next.a - prev.b) < 1e-6) return;
    // The line's direction and a point on it; the circle's centre and a point on it.
    const Segment& line = next.arc ? prev : next;
    const Segment& circle = next.arc ? next : prev;
    const Point origin = line.b;
    const Point rot = std::conj(line.a - line.b) / std::abs(line.a - line.b);
    const Point on_circle = (circle.b - origin) * rot;
    const Point centre = (circle.c - origin) * rot;
    double h = std::norm(centre - on_circle) - centre.imag() * centre.imag();
    h = h < 0 ? 0 : std::sqrt(h);
    const Point s1 = (centre.real() + h) / rot + origin, s2 = (centre.real() - h) / rot + origin;
    next.a = prev.b = std::abs(next.a - s1) < std::abs(next.a - s2) ? s1 : s2;
    return;
  }
  const double ra = std::abs(next.a - next.c), rb = std::abs(prev.a - prev.c), dc = std::abs(next.c - prev.c);
  const double cos_b = (dc * dc + ra * ra - rb * rb) / 2.0 / ra / dc;
  const double cos2 = std::min(cos_b * cos_b, 1.0);
  const Point rot(cos_b, std::sqrt(1 - cos2));
  prev.b = next.a = rot * (prev.c - next.c) / dc * ra + next.c;
}

/// The profile with its normalising transform (a 90° turn and mirror images of Z and X).
class Profile {
 public:
  std::list<Segment> segs;

  void turn() {
    for (Segment& s : segs) {
      s.a *= -kI;
      s.b *= -kI;
      s.c *= -kI;
    }
    compose(0, 1, -1, 0);
  }
  /// Mirror so that the profile's end lies towards +X and -Z of its first point.
  void normalise() {
    const Point d = segs.front().b - segs.back().b;
    if (d.imag() > 0) {
      for (Segment& s : segs) {
        s.a = std::conj(s.a);
        s.b = std::conj(s.b);
        s.c = std::conj(s.c);
        s.ccw = !s.ccw;
      }
      compose(1, 0, 0, -1);
    }
    if (d.real() < 0) {
      for (Segment& s : segs) {
        s.a = -std::conj(s.a);
        s.b = -std::conj(s.b);
        s.c = -std::conj(s.c);
        s.ccw = !s.ccw;
      }
      compose(-1, 0, 0, 1);
    }
  }
  void offset(double distance);

  /// Output in the program's frame.
  void rapid(std::vector<Move>& out, Point p) const { out.push_back({Move::Kind::rapid, back(p), {}}); }
  void line(std::vector<Move>& out, Point p) const { out.push_back({Move::Kind::line, back(p), {}}); }
  void arc(std::vector<Move>& out, bool ccw, Point c, Point p) const {
    // rs274 2.9 makes no arc that ends where the tool stands (0.0001 in program units).
    if (!out.empty() && std::abs(out.back().end.real() - back(p).real()) < 1e-4 &&
        std::abs(out.back().end.imag() - back(p).imag()) < 1e-4)
      return;
    const bool mirrored = m_[0] * m_[3] - m_[1] * m_[2] < 0;
    out.push_back({(ccw != mirrored) ? Move::Kind::arc_ccw : Move::Kind::arc_cw, back(p), back(c)});
  }
  void draw(std::vector<Move>& out, const Segment& s) const {
    if (s.arc) arc(out, s.ccw, s.c, s.b);
    else line(out, s.b);
  }

 private:
  /// Forward transform (z, x) → (m0 z + m1 x, m2 z + m3 x); left-multiplied by each new step.
  void compose(double a, double b, double c, double d) {
    const double n0 = a * m_[0] + b * m_[2], n1 = a * m_[1] + b * m_[3];
    const double n2 = c * m_[0] + d * m_[2], n3 = c * m_[1] + d * m_[3];
    m_ = {n0, n1, n2, n3};
  }
  [[nodiscard]] Point back(Point p) const {
    const double det = m_[0] * m_[3] - m_[1] * m_[2];  // ±1
    const double z = (m_[3] * p.real() - m_[1] * p.imag()) / det;
    const double x = (-m_[2] * p.real() + m_[0] * p.imag()) / det;
    return {z, x};
  }
  std::array<double, 4> m_{1, 0, 0, 1};
};

/// Offsets every element but the approach by `distance` towards the start point (in steps no
/// larger than half the smallest element, rounding convex corners with arcs), then joins them.
void Profile::offset(double distance) {
  normalise();
  const Point v1 = segs.front().b - segs.front().a, v2 = segs.back().a - segs.front().a;
  if ((v1 / v2).imag() < 0) distance = -distance;
  Segment approach = segs.front();
  segs.pop_front();
  if (segs.empty()) throw Failure{"the profile needs at least two moves"};
  double done = 0;
  for (int guard = 0; done != distance; ++guard) {
    if (segs.empty() || guard > 100000) throw Failure{"profile vanishes when offset by D"};
    double step = 1e9;
    for (const Segment& s : segs) step = std::min(step, size_of(s) / 2);
    step = std::min(step, std::abs(distance - done));
    if (distance < 0) step = -step;
    for (auto p = segs.begin(); p != segs.end();) {
      shift_normal(*p, step);
      p = size_of(*p) < 1e-3 ? segs.erase(p) : std::next(p);
    }
    if (segs.empty()) throw Failure{"profile vanishes when offset by D"};
    for (auto p = segs.begin(); p != std::prev(segs.end()); ++p) {
      auto n = std::next(p);
      if ((p->b - n->a).real() > 1e-2) {
        Segment s = *p, e = *n;
        shift_normal(s, -step);
        shift_normal(e, -step);
        segs.insert(n, Segment{true, distance > 0, p->b, n->a, (s.b + e.a) / 2.0});
        ++p;
      }
    }
    for (auto p = segs.begin(); p != std::prev(segs.end()); ++p) {
      if (!monotonic(*p)) {
        if (p == segs.begin()) throw Failure{"Not monotonic"};
        auto pp = std::prev(p);
        if (size_of(*p) < size_of(*pp)) segs.erase(p);
        else segs.erase(pp);
        p = segs.begin();
        if (std::next(p) == segs.end()) break;
      }
      auto n = std::next(p);
      if (size_of(*p) < 1e-3) {
        segs.erase(p);
        p = segs.begin();
        if (std::next(p) == segs.end()) break;
      } else {
        join(*p, *n);
      }
    }
    done += step;
  }
  for (auto p = segs.begin(); p != std::prev(segs.end()); ++p) {
    auto n = std::next(p);
    const Point mid = (p->b + n->a) / 2.0;
    p->b = n->a = mid;
  }
  approach.b = segs.front().a;
  segs.push_front(approach);
}

// -- roughing ----------------------------------------------------------------------------------

class Rougher {
 public:
  Rougher(const Profile& prof, std::vector<Move>& out, double delta, double retract)
      : prof_(prof), out_(out), delta_(delta), escape_(retract * Point(1, 1)) {
    segs_.assign(prof.segs.begin(), prof.segs.end());
  }

  /// Cuts from `loc` along element `p` on. Variant 0: layers and every pocket; 1 (G7x.1): one
  /// pass of layers, then along the profile; 2 (G7x.2): no first pass, then as 3; 3: the pockets
  /// only, each cut in layers from the level where the pocket before it began (`starts_`).
  void pocket(int variant, Point& loc, std::size_t p) {
    if (starts_.empty()) starts_.push_back(loc);
    double x = starts_.back().imag();
    if (variant == 2) {
      for (; p < segs_.size(); ++p)
        if (dive(p, loc, -1e9, p == 0)) break;
      variant = 3;
    }
    while (p < segs_.size()) {
      if (++guard_ > 10000000) throw Failure{"roughing does not end"};
      while (x - kTol > loc.imag()) x -= delta_;
      if (dive(p, loc, x, p == 0)) {
        if (variant == 1) {
          for (; p < segs_.size(); ++p) climb_only(p, loc);
        } else {
          for (; p < segs_.size(); ++p)
            if (climb(p, loc)) {
              if (variant == 3) {
                if (loc.imag() > starts_.back().imag() && starts_.size() > 1) starts_.pop_back();
                if (starts_.size() == 1) starts_.push_back(loc);
              }
              pocket(variant, loc, p);
              return;
            }
        }
        return;
      }
      if (std::abs(loc.imag() - x) > kTol) {
        ++p;
        continue;
      }
      for (std::size_t ip = p; ip < segs_.size(); ++ip) {
        std::deque<double> zs;
        crossings(segs_[ip], loc.imag(), zs);
        if (zs.empty()) continue;
        const double dest_z = ip != p ? zs.front() : zs.back();
        const double dist = std::abs(dest_z - loc.real());
        // Only a crossing that lies ahead (towards -Z) ends the layer.
        if (dest_z - kTol > loc.real()) continue;
        if (dist < kTol) {
          if (p == ip) continue;  // the diving element itself, at the point reached
          if (std::abs(loc - segs_[ip].a) < kTol) {
            p = ip;  // another element starts here: continue along it
            break;
          }
          x -= delta_;  // an element of no length at this level: the layer is done
          break;
        }
        Point dest = loc;
        dest.real(dest_z);
        prof_.line(out_, dest);
        const double scale = std::min(1.0, dist / 2 / escape_.real());
        dest += scale * escape_;
        prof_.rapid(out_, dest);
        prof_.rapid(out_, loc - std::conj(scale * escape_));
        if (p == 0) prof_.rapid(out_, loc);
        else prof_.line(out_, loc);
        x -= delta_;
        break;
      }
    }
  }

  std::vector<Segment> segs_;

 private:
  /// Follows a falling element down to level x (or its end); false when it is not falling.
  bool dive(std::size_t i, Point& loc, double x, bool fast) {
    const Segment& s = segs_[i];
    if (!s.arc) {
      if (s.a.imag() <= s.b.imag() + kTol) return true;
      Point to = s.b;
      if (x >= s.b.imag()) {
        std::deque<double> zs;
        crossings(s, x, zs);
        if (zs.empty()) throw Failure{"x too large in straight dive"};
        to = Point(zs.front(), x);
      }
      if (fast) prof_.rapid(out_, to);
      else prof_.line(out_, to);
      loc = to;
      return false;
    }
    // An arc whose end is reached, or lies behind, is passed without a move (rs274 2.9).
    if (std::abs(loc - s.b) < kTol || (loc - s.b).real() <= kTol) {
      loc = s.b;
      return false;
    }
    std::deque<double> zs;
    crossings(s, x, zs);
    if (zs.empty()) crossings(s, x - kTol, zs);
    if (s.ccw) {
      if (loc.real() - kTol > s.c.real()) return true;
      if (zs.empty() || zs.back() > s.c.real()) {
        prof_.arc(out_, true, s.c, s.b);
        loc = s.b;
      } else {
        const Point ep(zs.back(), x);
        prof_.arc(out_, true, s.c, ep);
        loc = ep;
      }
      return false;
    }
    if (loc.real() <= s.c.real()) return true;
    if (zs.empty()) {
      prof_.arc(out_, false, s.c, s.b);
      loc = s.b;
    } else if (zs.front() >= s.c.real()) {
      const Point ep(zs.front(), x);
      prof_.arc(out_, false, s.c, ep);
      loc = ep;
    }
    // else: met on its rising side only; the layer level steps on.
    return false;
  }

  /// Follows a rising element; true where a pocket starts (the profile falls again).
  bool climb(std::size_t i, Point& loc) {
    const Segment& s = segs_[i];
    if (!s.arc) {
      if (s.b.imag() + kTol < s.a.imag()) return true;
      if (std::abs(loc - s.a) > kTol) throw Failure{"How did we get here?"};
      prof_.line(out_, s.b);
      loc = s.b;
      return false;
    }
    if (!s.ccw) {
      if (loc.real() > s.c.real()) return true;
      if (std::abs(loc - s.b) > 1e-3) prof_.arc(out_, false, s.c, s.b);
      loc = s.b;
      return false;
    }
    if (loc.real() < s.c.real()) return true;
    const Point ep = top_of(s);
    if (std::abs(loc - ep) > 1e-3) prof_.arc(out_, true, s.c, ep);
    loc = ep;
    return true;
  }

  /// G7x.1: after the first cut, follow only the rising parts, skipping pockets.
  void climb_only(std::size_t i, Point& loc) {
    const Segment& s = segs_[i];
    std::deque<double> zs;
    if (!s.arc) {
      if (s.b.imag() < s.a.imag()) return;
      crossings(s, loc.imag(), zs);
      if (zs.empty()) return;
      loc.real(zs.front());
      prof_.line(out_, loc);
      prof_.line(out_, s.b);
      loc = s.b;
      return;
    }
    crossings(s, loc.imag(), zs);
    if (zs.empty()) return;
    if (!s.ccw) {
      if (zs.back() > s.c.real()) return;
      loc.real(zs.back());
      prof_.line(out_, loc);
      if (std::abs(loc - s.b) > 1e-3) prof_.arc(out_, false, s.c, s.b);
      loc = s.b;
      return;
    }
    if (zs.front() < s.c.real()) return;
    loc.real(zs.front());
    prof_.line(out_, loc);
    const Point ep = top_of(s);
    if (std::abs(loc - ep) > 1e-3) prof_.arc(out_, true, s.c, ep);
    loc = ep;
  }

  /// A G3 element ends at its top when it would run past it.
  static Point top_of(const Segment& s) {
    if (s.b.real() >= s.c.real()) return s.b;
    return Point(s.c.real(), s.c.imag() + std::abs(s.a - s.c));
  }

  const Profile& prof_;
  std::vector<Move>& out_;
  double delta_;
  Point escape_;
  long guard_ = 0;
  std::vector<Point> starts_;  ///< where the pockets being cut began (the first: the cycle's start)
};

/// The corner finishes of the profile (LinuxCNC docs, G71-G72: "A" rounds, "C" chamfers the
/// corner at the end of the block): the neighbours of a placeholder are offset by its size towards
/// the side where they overlap (tried on one side, then the other: on the wrong side a gap opens
/// along Z), the offset elements are joined, and their meeting point taken back onto each
/// neighbour gives the two points where the finish touches them: a fillet is the arc of that size
/// about the meeting point, a chamfer the straight between the two points. Done in the normalised
/// frame, before the monotonic check (rs274 2.9 order). Then every element shorter than 0.001
/// (program units; arcs: chord or radius) is dropped, corners or not, as rs274 drops them.
void finish_corners(Profile& prof) {
  auto& segs = prof.segs;
  for (auto h = std::next(segs.begin()); segs.size() >= 3 && h != std::prev(segs.end()); ++h) {
    if (h->corner == 0) continue;
    Segment& prev = *std::prev(h);
    Segment& next = *std::next(h);
    double size = h->corner;
    Segment p = prev, n = next;
    shift_normal(p, size);
    shift_normal(n, size);
    if ((p.b - n.a).real() > 1e-2) {
      size = -size;
      p = prev;
      n = next;
      shift_normal(p, size);
      shift_normal(n, size);
    }
    if ((p.b - n.a).real() > 1e-2) throw Failure{"Corner finish failed"};
    join(p, n);
    const Point centre = (p.b + n.a) / 2.0;
    shift_normal(p, -size);
    shift_normal(n, -size);
    h->a = prev.b = p.b;
    h->b = next.a = n.a;
    if (h->arc) {
      h->c = centre;
      h->ccw = (h->a - centre).imag() > 0 || (h->b - centre).imag() > 0;
    }
    h->corner = 0;
  }
  std::erase_if(segs, [](const Segment& s) { return s.corner != 0 || size_of(s) < 1e-3; });
  if (segs.empty()) throw Failure{"the profile has no move longer than 0.001"};
}

/// An approach that would run towards +Z (in the normalised frame) starts level with its end
/// instead; then every element must be monotonic ("Not monotonic" from rs274 otherwise).
void straighten_entry(Profile& prof) {
  Segment& first = prof.segs.front();
  if ((first.b - first.a).real() > 0) first.a.real(first.b.real());
  for (const Segment& s : prof.segs)
    if (!monotonic(s)) throw Failure{"Not monotonic"};
}

/// G70: whether the profile is finished along X (turned by 90°) is decided on the profile without
/// its approach, normalised on its own first and last element; the approach then joins it and the
/// whole path is normalised (on the approach's end) and straightened as for roughing. So an
/// approach that runs away from the profile's direction (`G0 Z-12 X14` from Z4 before a profile
/// that runs towards +Z) does not turn the profile; it starts level with its end instead (rs274
/// 2.9: rapids Z first, then X).
void finish(const CycleWords& w, Profile& prof, std::vector<Move>& out) {
  if (prof.segs.size() < 2) throw Failure{"the profile needs at least two moves"};
  Profile body = prof;
  body.segs.pop_front();
  body.normalise();
  bool turned = false;
  for (const Segment& s : body.segs)
    if (!monotonic(s)) {
      body.turn();
      body.normalise();
      turned = true;
      break;
    }
  straighten_entry(body);
  if (turned) prof.turn();
  prof.normalise();
  finish_corners(prof);
  straighten_entry(prof);
  const int passes = static_cast<int>(w.passes);
  for (int pass = passes; pass > 0; --pass) {
    const double distance = (pass - 1) * (w.d - w.e) / w.passes + w.e;
    Profile path = prof;
    path.offset(distance);
    path.rapid(out, path.segs.front().a);
    path.rapid(out, path.segs.front().b);
    for (auto p = std::next(path.segs.begin()); p != path.segs.end(); ++p) path.draw(out, *p);
  }
}

void rough(const CycleWords& w, Profile& prof, std::vector<Move>& out) {
  if (w.cycle == 72) prof.turn();
  prof.normalise();
  finish_corners(prof);
  straighten_entry(prof);
  // Not normalised again after the offset (rs274 2.9): an offset approach whose end passes the
  // profile's end in X keeps the frame it was cut in.
  prof.offset(w.d);
  prof.rapid(out, prof.segs.front().a);
  const Segment last = prof.segs.back();
  if (last.b.imag() < prof.segs.front().a.imag()) {
    Point up = last.b;
    up.imag(prof.segs.front().a.imag());
    prof.segs.push_back(Segment{false, false, last.b, up, {}});
  }
  Rougher r(prof, out, w.increment, w.retract);
  Point loc = prof.segs.front().a;
  r.pocket(w.variant, loc, 0);
}

}  // namespace

std::string expand_linuxcnc(const CycleWords& w, std::vector<Segment> profile, std::vector<Move>& out) {
  if (profile.empty()) return "the profile subroutine has no moves";
  Profile prof;
  prof.segs.assign(profile.begin(), profile.end());
  prof.segs.front().a = w.start;
  try {
    if (w.cycle == 70) finish(w, prof, out);
    else rough(w, prof, out);
  } catch (const Failure& f) {
    return f.what;
  }
  return {};
}

// -- Fanuc G71 / G72 type I, G73 ----------------------------------------------------------------

namespace {

/// Program frame (z, x) → the frame the Fanuc roughing is worked out in: infeed towards -x, layers
/// cut towards -z. G72 swaps the axes first (its layers run along X, its infeed along Z).
struct FanucFrame {
  bool swap = false;
  double sz = 1, sx = 1;
  [[nodiscard]] Point fwd(Point p) const {
    const double z = swap ? p.imag() : p.real(), x = swap ? p.real() : p.imag();
    return {sz * z, sx * x};
  }
  [[nodiscard]] Point back(Point q) const {
    const double z = q.real() / sz, x = q.imag() / sx;
    return swap ? Point(x, z) : Point(z, x);
  }
  [[nodiscard]] bool mirrored() const { return (sz * sx < 0) != swap; }
  [[nodiscard]] Segment fwd(const Segment& s) const {
    Segment t = s;
    t.a = fwd(s.a);
    t.b = fwd(s.b);
    t.c = fwd(s.c);
    if (mirrored()) t.ccw = !s.ccw;
    return t;
  }
};

/// An arc's sweep holds direction `dir` (a unit point) strictly inside.
bool arc_passes(const Segment& s, Point dir) {
  const double a0 = std::arg(s.a - s.c), a1 = std::arg(s.b - s.c), ad = std::arg(dir);
  const double two_pi = 2 * std::acos(-1.0);
  const auto norm = [&](double a) {
    while (a < 0) a += two_pi;
    while (a >= two_pi) a -= two_pi;
    return a;
  };
  // Sweep measured counter-clockwise from the start (clockwise arcs: from the end).
  const double from = s.ccw ? a0 : a1, to = s.ccw ? a1 : a0;
  double sweep = norm(to - from);
  if (sweep < 1e-12) sweep = two_pi;  // a full circle
  const double at = norm(ad - from);
  return at > 1e-9 && at < sweep - 1e-9;
}

/// Type I: every element runs towards -z and never down in x (normalised frame).
bool fanuc_monotonic(const Segment& s) {
  const Point d = s.b - s.a;
  if (d.real() > 1e-9 || d.imag() < -1e-9) return false;
  if (!s.arc) return true;
  for (Point dir : {Point(1, 0), Point(0, 1), Point(-1, 0), Point(0, -1)})
    if (arc_passes(s, dir)) return false;
  return true;
}

struct FanucOut {
  const FanucFrame& f;
  std::vector<Move>& out;
  void rapid(Point p) const { out.push_back({Move::Kind::rapid, f.back(p), {}}); }
  void line(Point p) const { out.push_back({Move::Kind::line, f.back(p), {}}); }
  void move(bool rapid_move, Point p) const { rapid_move ? rapid(p) : line(p); }
  void draw(const Segment& s) const {
    if (!s.arc) return line(s.b);
    const bool ccw = s.ccw != f.mirrored();
    out.push_back({ccw ? Move::Kind::arc_ccw : Move::Kind::arc_cw, f.back(s.b), f.back(s.c)});
  }
};

}  // namespace

std::string expand_fanuc_rough(const FanucRough& w, std::vector<Segment> profile, std::vector<Move>& out) {
  if (profile.empty()) return "the profile has no move after its first block";
  for (Segment& s : profile) {
    s.a += w.allowance;
    s.b += w.allowance;
    s.c += w.allowance;
  }
  FanucFrame f;
  f.swap = w.facing;
  const Point a_prog = w.start, first = profile.front().a, last = profile.back().b;
  const double infeed = w.facing ? (first - a_prog).real() : (first - a_prog).imag();
  const double along = w.facing ? (last - first).imag() : (last - first).real();
  if (std::abs(along) < 1e-9)
    return w.facing ? "the profile does not run along X (its first and last points have the same X)"
                    : "the profile does not run along Z (its first and last points have the same Z)";
  f.sx = infeed < 0 ? 1 : -1;
  f.sz = along < 0 ? 1 : -1;
  for (Segment& s : profile) s = f.fwd(s);
  for (std::size_t i = 0; i < profile.size(); ++i)
    if (!fanuc_monotonic(profile[i]))
      return "alarm: element " + std::to_string(i + 1) +
             " of the profile (after its first block) does not run monotonically in both axes, as type I needs";
  const Point a = f.fwd(a_prog);
  const double z0 = a.real(), x0 = a.imag();
  const Point a2 = profile.front().a;  // A' with the allowance
  const double xb = a2.imag();
  if (!(xb < x0 - 1e-9))
    return "the start point does not lie outside the profile's first point (with the finishing allowance) in the "
           "direction of infeed; nothing is cut";
  const Point b2 = profile.back().b;
  // Where the layer at level x ends: the first point of the profile met going towards -z from
  // the start, or the closing line through B (C) where the profile lies below the level.
  const auto layer_end = [&](double x, double& z) {
    double best = -1e300;
    bool found = false;
    for (const Segment& s : profile) {
      std::deque<double> zs;
      crossings(s, x, zs);
      for (double zc : zs)
        if (zc < z0 - 1e-9 && zc > best) {
          best = zc;
          found = true;
        }
    }
    if (!found && x > b2.imag() - 1e-9 && b2.real() < z0 - 1e-9) {
      best = b2.real();
      found = true;
    }
    z = best;
    return found;
  };
  FanucOut o{f, out};
  const double e = w.escape;
  // One layer at x: infeed, cut to the profile, 45° escape of e, rapid back to the start's Z.
  const auto layer = [&](double x) {
    double zc = 0;
    if (!layer_end(x, zc)) return false;
    o.move(w.infeed_rapid, Point(z0, x));
    o.line(Point(zc, x));
    if (e > 0) o.rapid(Point(zc + e, x + e));
    o.rapid(Point(z0, x + e));
    return true;
  };
  int k = 1;
  for (;; ++k) {
    const double x = x0 - k * w.depth;
    if (x <= xb + 1e-9) break;
    if (k > 100000) return "more than 100000 layers; check the depth of cut";
    if (!layer(x)) return "a layer of the cut does not meet the profile ahead of the start point";
  }
  if (w.final_cut) {
    // Last: to A' (with the allowance) in the ns block's mode, then along the profile to B.
    o.move(w.infeed_rapid, a2);
    for (const Segment& s : profile) o.draw(s);
  } else if (!layer(xb)) {
    return "the last layer does not meet the profile ahead of the start point";
  }
  o.rapid(a);
  return {};
}

std::string expand_fanuc_pattern(Point start, Point relief, Point allowance, int passes, bool infeed_rapid,
                                 const std::vector<Segment>& profile, std::vector<Move>& out) {
  if (profile.empty()) return "the profile has no move after its first block";
  if (passes < 1) return "the number of divisions must be at least 1";
  const FanucFrame f;  // identity
  FanucOut o{f, out};
  for (int k = 1; k <= passes; ++k) {
    // Pass k of d is shifted by relief·(d-k)/(d-1) + allowance (one pass: the allowance alone).
    const double share = passes == 1 ? 0.0 : static_cast<double>(passes - k) / (passes - 1);
    const Point shift = relief * share + allowance;
    o.move(infeed_rapid, profile.front().a + shift);
    for (Segment s : profile) {
      s.a += shift;
      s.b += shift;
      s.c += shift;
      o.draw(s);
    }
    o.rapid(start);
  }
  return {};
}

}  // namespace postproc::gcode::turning
