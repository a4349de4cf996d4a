// analyseBounces: flight arcs, bounces, apexes, restitution and the end of the trajectory
// (vision/bounce_analysis.h).
#include "topo_gaussian/vision/bounce_analysis.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "topo_gaussian/common/error.h"
#include "topo_gaussian/common/number_text.h"
#include "topo_gaussian/common/oscillation.h"
#include "topo_gaussian/common/statistics.h"

namespace topo_gaussian::vision {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct Parabola {
  double t_ref = 0, c0 = 0, c1 = 0, c2 = 0;  ///< h = c0 + c1 τ + c2 τ², τ = t − t_ref
  double at(double t) const {
    const double s = t - t_ref;
    return c0 + c1 * s + c2 * s * s;
  }
};

/// Local extrema of h with hysteresis `prom`: +1 = maximum (apex candidate), −1 = minimum (contact).
std::vector<std::pair<int, int>> extrema(const std::vector<double>& h, double prom) {
  std::vector<std::pair<int, int>> ext;
  const int m = static_cast<int>(h.size());
  int dir = 0, cand = 0, lo = 0, hi = 0;
  for (int i = 1; i < m; ++i) {
    if (dir == 0) {
      if (h[i] > h[hi]) hi = i;
      if (h[i] < h[lo]) lo = i;
      if (h[hi] - h[lo] >= prom) {
        if (hi > lo) {
          if (lo > 0) ext.push_back({lo, -1});
          dir = +1;
          cand = hi;
        } else {
          if (hi > 0) ext.push_back({hi, +1});
          dir = -1;
          cand = lo;
        }
      }
    } else if (dir > 0) {
      if (h[i] > h[cand])
        cand = i;
      else if (h[cand] - h[i] >= prom) {
        ext.push_back({cand, +1});
        dir = -1;
        cand = i;
      }
    } else {
      if (h[i] < h[cand])
        cand = i;
      else if (h[i] - h[cand] >= prom) {
        ext.push_back({cand, -1});
        dir = +1;
        cand = i;
      }
    }
  }
  return ext;
}

}  // namespace

BounceFeatures analyseBounces(const std::vector<double>& t_in, const std::vector<double>& h_in, double h_min,
                              double h_max, const BounceOptions& o, const std::vector<double>* across_in) {
  if (t_in.size() != h_in.size() || (across_in && across_in->size() != t_in.size()))
    throw TopoError("bounce analysis", "times and heights differ in length", "pass one height per time");
  BounceFeatures f;
  f.restitution_heights_mean = f.restitution_times_mean = kNaN;
  if (t_in.size() < 8) {
    f.message = "no bounce: too few samples (" + std::to_string(t_in.size()) + ")";
    return f;
  }
  // the first run without a gap > max_gap_s that holds at least max(8, 10 %) of the samples: a lost
  // object ends the trajectory (a short run before it, e.g. a hand in view, is skipped)
  std::size_t best0 = 0, best1 = 0, s0 = 0;
  const std::size_t need = std::max<std::size_t>(8, t_in.size() / 10);
  for (std::size_t i = 1; i <= t_in.size(); ++i)
    if (i == t_in.size() || t_in[i] - t_in[i - 1] > o.max_gap_s) {
      if (best1 == 0 && i - s0 >= need) best0 = s0, best1 = i;
      s0 = i;
    }
  if (best1 == 0) best1 = t_in.size();
  std::vector<std::string> notes;
  const std::vector<double> t(t_in.begin() + best0, t_in.begin() + best1),
      h(h_in.begin() + best0, h_in.begin() + best1);
  std::vector<double> x;
  if (across_in) x.assign(across_in->begin() + best0, across_in->begin() + best1);
  if (best1 < t_in.size()) {
    f.end_reason = "the object was lost for " + fixedText(t_in[best1] - t_in[best1 - 1], 2) +
                   " s at t = " + fixedText(t_in[best1 - 1], 2) + " s";
  }
  if (best0 > 0)
    notes.push_back("analysed from t = " + fixedText(t.front(), 2) + " s, after the object was lost for " +
                    fixedText(t_in[best0] - t_in[best0 - 1], 2) + " s");
  f.end_time_s = t.back();
  const int n = static_cast<int>(t.size());
  const double hmax = *std::max_element(h.begin(), h.end()), hmin = *std::min_element(h.begin(), h.end());
  const double prom = o.min_prominence_px > 0 ? o.min_prominence_px : std::max(3.0, 0.05 * (hmax - hmin));
  const auto ext = extrema(h, prom);
  std::vector<int> contact;
  for (const auto& e : ext)
    if (e.second < 0) contact.push_back(e.first);
  std::vector<double> dts;
  for (int i = 1; i < n; ++i) dts.push_back(t[i] - t[i - 1]);
  const double dt = median(dts);

  // arcs: [start or highest point before the first contact, c0), (c0, c1), ..., (c_last, end]
  const int nc = static_cast<int>(contact.size());
  std::vector<Parabola> fit(nc + 1);
  f.arcs.resize(nc + 1);
  std::vector<int> arc_end(nc + 1, -1);
  std::vector<std::pair<int, int>> span(nc + 1,
                                        {0, -1});  ///< last sample of a free-flight prefix (arcs that end in a pick-up)
  auto fitArc = [&](int i0, int i1, FlightArc& a, Parabola& p) {
    a = FlightArc();
    if (i1 - i0 + 1 < o.min_arc_samples) return;
    double c[3];
    if (!oscillation::fitPolynomial(t.data() + i0, h.data() + i0, i1 - i0 + 1, t[i0], 2, c, nullptr)) return;
    p = Parabola{t[i0], c[0], c[1], c[2]};
    a.t0 = t[i0];
    a.t1 = t[i1];
    a.accel_px_s2 = 2 * c[2];
    double ss = 0, lo = 1e300, hi = -1e300;
    for (int i = i0; i <= i1; ++i) {
      const double r = h[i] - p.at(t[i]);
      ss += r * r;
      lo = std::min(lo, h[i]);
      hi = std::max(hi, h[i]);
    }
    a.rms_px = std::sqrt(ss / (i1 - i0 + 1));
    if (c[2] < 0) {
      a.apex_t = t[i0] - c[1] / (2 * c[2]);
      a.apex_h = p.at(a.apex_t);
      a.apex_inside =
          a.apex_t >= a.t0 - 0.5 * dt && a.apex_t <= a.t1 + 0.5 * dt && a.apex_h >= h_min && a.apex_h <= h_max;
    }
    const double tol = std::max(2.0, 0.025 * (hi - lo));
    a.flight = c[2] < 0 && a.rms_px <= tol;
    if (a.flight && !x.empty()) {  // no force across gravity in flight: a straight line
      double cx[3];
      if (oscillation::fitPolynomial(t.data() + i0, x.data() + i0, i1 - i0 + 1, t[i0], 1, cx, nullptr)) {
        double sx = 0;
        for (int i = i0; i <= i1; ++i) {
          const double rx = x[i] - (cx[0] + cx[1] * (t[i] - t[i0]));
          sx += rx * rx;
        }
        if (std::sqrt(sx / (i1 - i0 + 1)) > tol) a.flight = false;
      }
    }
  };
  for (int k = 0; k <= nc; ++k) {
    int i0 = k == 0 ? 0 : contact[k - 1] + 1;
    const int i1 = k == nc ? n - 1 : contact[k] - 1;
    if (k == 0 && nc > 0) i0 = static_cast<int>(std::max_element(h.begin(), h.begin() + contact[0]) - h.begin());
    fitArc(i0, i1, f.arcs[k], fit[k]);
    span[k] = {i0, i1};
  }
  {
    // an arc that ends in a pick-up or a roll: the longest start of it in free flight at the whole
    // arcs' g (within 25 %; a long stretch of hand motion can fit a flatter parabola)
    std::vector<double> full;
    for (const auto& a : f.arcs)
      if (a.flight) full.push_back(-a.accel_px_s2);
    const double g0 = full.empty() ? 0.0 : median(full);
    for (int k = 1; k <= nc && g0 > 0; ++k) {
      const double gk = -f.arcs[k].accel_px_s2;
      if (f.arcs[k].flight && gk >= 0.5 * g0 && gk <= 2.0 * g0) continue;
      const int i0 = span[k].first, i1 = span[k].second;
      for (int j = i1 - 1; j >= i0 + o.min_arc_samples - 1; --j) {
        FlightArc a;
        Parabola p;
        fitArc(i0, j, a, p);
        if (a.flight && std::abs(-a.accel_px_s2 - g0) <= 0.25 * g0) {
          f.arcs[k] = a;
          fit[k] = p;
          arc_end[k] = j;
          break;
        }
      }
    }
  }
  std::vector<double> acc;
  for (const auto& a : f.arcs)
    if (a.flight) acc.push_back(-a.accel_px_s2);
  std::string scale_problem;
  if (!acc.empty() && o.object_diameter_px > 0) {
    const double per_d = median(acc) / o.object_diameter_px;
    if (per_d < o.min_g_diameters || per_d > o.max_g_diameters) {
      scale_problem = "the arcs accelerate at " + fixedText(median(acc), 0) + " px/s² = " + fixedText(per_d, 1) +
                      " object diameters/s² (the object is " + fixedText(o.object_diameter_px, 0) +
                      " px across); free fall of an object 1 cm – 1 m across is 10–1000 diameters/s² (a clip slowed k "
                      "times: divided by k²), and below " +
                      fixedText(o.min_g_diameters, 0) +
                      " these are not flights (a swinging, sliding or carried object)";
      for (auto& a : f.arcs) a.flight = false;
      acc.clear();
    }
  }
  if (!acc.empty()) {
    f.gravity_px_s2 = median(acc);
    for (auto& a : f.arcs)
      if (a.flight && (-a.accel_px_s2 > 2.0 * f.gravity_px_s2 || -a.accel_px_s2 < 0.5 * f.gravity_px_s2))
        a.flight = false;
  }
  // the chain of bounces: contacts with free flight on both sides, ending at the first that has none after
  int first = -1, last = -1;
  for (int k = 0; k < nc; ++k) {
    const bool ok = f.arcs[k].flight && arc_end[k] < 0 && f.arcs[k + 1].flight;
    if (ok && first < 0) first = k;
    if (ok && first >= 0) last = k;
    if (first >= 0 && (!ok || arc_end[k + 1] >= 0)) {
      const double te = ok ? t[arc_end[k + 1]] : t[contact[k]];
      f.end_time_s = te;
      f.end_reason = "the motion after t = " + fixedText(te, 2) +
                     " s is not free flight (the object was picked up, rolls or stopped)";
      break;
    }
  }
  if (first < 0) {
    f.message = nc == 0 ? "no bounce: the height never rises again after falling"
                        : "no bounce: " + std::to_string(nc) +
                              " low point(s), but none has a free-flight arc (a parabola falling with one g) on "
                              "both sides";
    if (!scale_problem.empty()) f.message = "no bounce: " + scale_problem;
    if (!f.end_reason.empty()) f.message += "; " + f.end_reason;
    return f;
  }
  for (int k = first; k <= last; ++k) {
    // where the parabolas before and after meet, nearest the sample minimum
    const double tc = t[contact[k]];
    double best_t = tc, best_d = 1e300;
    const int steps = 200;
    double prev = fit[k].at(tc - 2 * dt) - fit[k + 1].at(tc - 2 * dt);
    for (int s = 1; s <= steps; ++s) {
      const double tt = tc - 2 * dt + 4 * dt * s / steps;
      const double v = fit[k].at(tt) - fit[k + 1].at(tt);
      if ((v <= 0) != (prev <= 0) && std::abs(tt - tc) < best_d) best_d = std::abs(tt - tc), best_t = tt;
      prev = v;
    }
    f.bounce_times_s.push_back(best_t);
    f.bounce_h_px.push_back(best_d < 1e300 ? fit[k].at(best_t) : h[contact[k]]);
  }
  // The arc before the first bounce is a release only if the object starts it at its top (let go from
  // rest). One that first rises in free flight followed a bounce or a throw: after a low point at the
  // floor line that bounce is placed where the rising parabola meets the floor line (its fall was not
  // free flight in the track: blurred, hidden or in the hand); otherwise it is named as missing.
  const FlightArc& rel = f.arcs[first];
  bool rising = false;
  int inferred = 0;  ///< 1: a bounce before the chain's first, placed from its rising arc alone
  std::string start_note;
  if (first == 0) {
    // the first arc starts at its highest sample: the samples before it rose to it in the same flight?
    const int top = span[0].first;
    if (top >= 2 && h[top] - h[0] >= prom) {
      FlightArc whole;
      Parabola p;
      fitArc(0, span[0].second, whole, p);
      rising = whole.flight && std::abs(-whole.accel_px_s2 - f.gravity_px_s2) <= 0.25 * f.gravity_px_s2;
      if (rising)
        start_note = "the object is already rising at t = " + fixedText(t[0], 2) + " s (" +
                     fixedText(std::abs(p.at(t[0] + 1e-3) - p.at(t[0])) * 1e3, 0) +
                     " px/s): it was not let go in view (a bounce or a throw before the first bounce found), so "
                     "there is no release height";
    }
  } else if (rel.apex_inside && rel.apex_h - fit[first].at(rel.t0) >= prom) {
    rising = true;
    const Parabola& p = fit[first];
    const double hb = f.bounce_h_px.front(), tc = t[contact[first - 1]];
    const double disc = p.c1 * p.c1 - 4 * p.c2 * (p.c0 - hb);
    const double tb = disc >= 0 ? p.t_ref + (-p.c1 + std::sqrt(disc)) / (2 * p.c2) : kNaN;  // the earlier root
    if (std::isfinite(tb) && std::abs(tb - tc) <= 2 * dt && tb < rel.t0) {
      inferred = 1;
      f.bounce_times_s.insert(f.bounce_times_s.begin(), tb);
      f.bounce_h_px.insert(f.bounce_h_px.begin(), hb);
      start_note = "the bounce at " + fixedText(tb, 3) +
                   " s is placed where its rising arc meets the next bounce's floor line (the fall into it is not "
                   "free flight in the track: blurred, hidden or still in the hand), so there is no release height";
    } else {
      start_note = "a bounce before the first bounce found was missed: the object rises from t = " +
                   fixedText(rel.t0, 2) + " s after a low point at " + fixedText(tc, 2) +
                   " s that has no free-flight arc before it, so there is no release height";
    }
  }
  double floor = 0;
  for (double v : f.bounce_h_px) floor += v;
  f.floor_h_px = floor / f.bounce_h_px.size();
  // apexes of the arcs in the chain (the one before the first bounce: the release, unless it rose first)
  for (int k = first; k <= last + 1; ++k) {
    const FlightArc& a = f.arcs[k];
    if (!a.apex_inside) continue;
    if (k == first && !inferred) continue;  // the release arc's top is the release height, below
    f.apex_times_s.push_back(a.apex_t);
    f.apex_h_px.push_back(a.apex_h);
    f.apex_heights_px.push_back(a.apex_h - f.bounce_h_px[k - 1 - first + inferred]);  // above the bounce it rose from
  }
  // the release: the arc's vertex when it lies inside it, else its highest sample (a ball let go from
  // rest in a hand; the arc starts at its highest sample)
  double highest = -1e300;
  for (int i = 0; i < n; ++i)
    if (t[i] >= rel.t0 && t[i] <= rel.t1) highest = std::max(highest, h[i]);
  const double release_h = rel.apex_inside ? rel.apex_h : highest;
  f.release_height_px = rising ? kNaN : release_h - f.bounce_h_px.front();
  // restitution per bounce
  std::vector<double> eh, et;
  if (inferred) {  // nothing is known of the fall into the placed bounce
    f.restitution_from_heights.push_back(kNaN);
    f.restitution_from_times.push_back(kNaN);
  }
  for (int k = first; k <= last; ++k) {
    const FlightArc &before = f.arcs[k], &after = f.arcs[k + 1];
    const double tb = f.bounce_times_s[k - first + inferred];
    // both heights above this bounce's contact point (the floor line can drift: a ball coming nearer)
    const double hb = f.bounce_h_px[k - first + inferred];
    const double Hb = (k == first && !rising ? release_h : (before.apex_inside ? before.apex_h : kNaN)) - hb;
    const double Ha = (after.apex_inside ? after.apex_h : kNaN) - hb;
    const double e_h = Hb > 0 && Ha > 0 ? std::sqrt(Ha / Hb) : kNaN;
    const double fall = before.apex_inside ? tb - before.apex_t : kNaN;
    const double rise = after.apex_inside ? after.apex_t - tb : kNaN;
    const double e_t = fall > 0 && rise > 0 ? rise / fall : kNaN;
    f.restitution_from_heights.push_back(e_h);
    f.restitution_from_times.push_back(e_t);
    if (std::isfinite(e_h)) eh.push_back(e_h);
    if (std::isfinite(e_t)) et.push_back(e_t);
  }
  if (!eh.empty()) f.restitution_heights_mean = median(eh);
  if (!et.empty()) f.restitution_times_mean = median(et);
  // confidence: fit quality of the chain's arcs and agreement of their accelerations
  std::vector<double> quality, chain_acc;
  for (int k = first; k <= last + 1; ++k) {
    const FlightArc& a = f.arcs[k];
    const double rise = std::max(1.0, a.apex_h - f.floor_h_px);
    quality.push_back(std::max(0.0, 1.0 - 0.5 * a.rms_px / std::max(2.0, 0.025 * rise)));
    chain_acc.push_back(-a.accel_px_s2);
  }
  double spread = 0;
  if (chain_acc.size() >= 2) {
    const double m = median(chain_acc);
    std::vector<double> d;
    for (double v : chain_acc) d.push_back(std::abs(v - m));
    spread = 1.4826 * median(d) / m;
  }
  f.confidence = median(quality) / (1.0 + (spread / 0.15) * (spread / 0.15));
  std::string b = std::to_string(f.bounce_times_s.size()) + " bounce(s) at";
  for (double v : f.bounce_times_s) b += " " + fixedText(v, 3);
  b += " s, " + std::to_string(f.apex_times_s.size()) + " apex(es)";
  if (!f.apex_heights_px.empty()) {
    b += " of height";
    for (double v : f.apex_heights_px) b += " " + fixedText(v, 1);
    b += " px above the bounce each rose from";
  }
  if (std::isfinite(f.release_height_px))
    b += ", released " + fixedText(f.release_height_px, 1) + " px above the first bounce";
  if (std::isfinite(f.restitution_heights_mean))
    b += "; restitution " + fixedText(f.restitution_heights_mean, 3) + " from heights";
  if (std::isfinite(f.restitution_times_mean))
    b += ", " + fixedText(f.restitution_times_mean, 3) + " from flight times";
  notes.insert(notes.begin(), b);
  if (!start_note.empty()) notes.insert(notes.begin() + 1, start_note);
  if (!f.end_reason.empty())
    notes.push_back("the trajectory ends at " + fixedText(f.end_time_s, 2) + " s: " + f.end_reason);
  for (std::size_t i = 0; i < notes.size(); ++i) f.message += (i ? "; " : "") + notes[i];
  return f;
}

}  // namespace topo_gaussian::vision
