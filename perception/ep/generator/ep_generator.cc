#include "perception/ep/generator/ep_generator.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <vector>

#include "common/cpu/hot_loop.h"

namespace epmap::ep {

namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

using Clock = std::chrono::steady_clock;
double MsBetween(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

void CheckCamera(const stereo::RectifiedGeometry& camera) {
  if (camera.width <= 0 || camera.height <= 0 || !(camera.fx > 0) || !(camera.fy > 0) ||
      !(camera.baseline_m > 0)) {
    throw std::invalid_argument("EP generator: camera geometry is not set (size, focal, baseline)");
  }
}

void CheckInputs(const MapState& s, const stereo::RectifiedGeometry& camera,
                 const Eigen::Isometry3d& T, const PredictionParams& params) {
  CheckCamera(camera);
  params.Validate();
  const cv::Size size(camera.width, camera.height);
  if (s.disparity.type() != CV_32FC1 || s.disparity.size() != size) {
    throw std::invalid_argument("EP generator: disparity must be CV_32FC1 of the camera's size");
  }
  if (s.offsets.type() != CV_16SC2 || s.offsets.size() != size) {
    throw std::invalid_argument("EP generator: offsets must be CV_16SC2 of the camera's size");
  }
  if (s.flags.type() != CV_8UC1 || s.flags.size() != size) {
    throw std::invalid_argument("EP generator: flags must be CV_8UC1 of the camera's size");
  }
  if (s.image.type() != CV_8UC1 || s.image.size() != size) {
    throw std::invalid_argument("EP generator: image must be CV_8UC1 of the camera's size");
  }
  if (s.accumulated.type() != CV_32FC1 ||
      s.accumulated.size() != ComparisonGrid(camera, params.image_step)) {
    throw std::invalid_argument(
        "EP generator: accumulated must be CV_32FC1 of the comparison grid's size");
  }
  if (!T.matrix().allFinite()) throw std::invalid_argument("EP generator: motion is not finite");
}

// The working state of one prediction: the moved points (disparity, 0 = empty, and offset
// from the pixel centre) and their flags, all of one frame's size.
struct Splat {
  int W = 0, H = 0;
  cv::Mat offsets;    // CV_16SC2, in 1 / kOffsetScale px
  cv::Mat flags;      // CV_8U
  cv::Mat disparity;  // CV_32F, 0 = empty

  // The point at (u + du, v + dv) at disparity d (du, dv in pixels).
  void Set(int u, int v, float d, float du, float dv, uint8_t f) {
    int16_t* o = offsets.ptr<int16_t>(v) + 2 * u;
    o[0] = ToOffset(du);
    o[1] = ToOffset(dv);
    flags.at<uint8_t>(v, u) = f;
    disparity.at<float>(v, u) = d;
  }
  // The point on pixel (u, v)'s ray (its centre) at disparity d.
  void SetOnRay(int u, int v, float d, uint8_t f) { Set(u, v, d, 0.0F, 0.0F, f); }
  // Where the point held by (u, v) lies, relative to that pixel's centre (pixels).
  float OffsetU(int u, int v) const {
    return static_cast<float>(offsets.ptr<int16_t>(v)[2 * u]) * (1.0F / kOffsetScale);
  }
  float OffsetV(int u, int v) const {
    return static_cast<float>(offsets.ptr<int16_t>(v)[2 * u + 1]) * (1.0F / kOffsetScale);
  }

  // Rounded to the nearest unit (by truncation of a positive number: no call to lround).
  static int16_t ToOffset(float px) {
    constexpr float kBias = 32768.0F;
    return static_cast<int16_t>(static_cast<int>(px * kOffsetScale + kBias + 0.5F) - 32768);
  }
};

void ExtendFootprints(const PredictionParams& params, Splat* s) {
  struct Copy {
    int u, v, from_u, from_v;
  };
  const float radius = static_cast<float>(params.splat_radius_px);
  const float max_step = static_cast<float>(params.crack_max_step_px);
  const int H = s->H, W = s->W;
  std::vector<std::vector<Copy>> copies(static_cast<size_t>(H));
  cv::parallel_for_(cv::Range(0, H), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v) {
      const float* d_mid = s->disparity.ptr<float>(v);
      for (int u = 0; u < W; ++u) {
        if (d_mid[u] > 0) continue;
        int best_u = -1, best_v = -1;
        float best_d = 0, best_dist2 = 1e30F;
        for (int dv = -1; dv <= 1; ++dv) {
          const int vn = v + dv;
          if (vn < 0 || vn >= H) continue;
          const float* d_row = s->disparity.ptr<float>(vn);
          for (int du = -1; du <= 1; ++du) {
            const int un = u + du;
            if (un < 0 || un >= W || !(d_row[un] > 0)) continue;
            // The neighbour's projection relative to this pixel's centre.
            const float ou = static_cast<float>(du) + s->OffsetU(un, vn);
            const float ov = static_cast<float>(dv) + s->OffsetV(un, vn);
            if (std::abs(ou) > radius || std::abs(ov) > radius) continue;
            const float d = d_row[un], dist2 = ou * ou + ov * ov;
            const bool better =
                best_u < 0 || (std::abs(d - best_d) > max_step ? d > best_d : dist2 < best_dist2);
            if (better) {
              best_u = un;
              best_v = vn;
              best_d = d;
              best_dist2 = dist2;
            }
          }
        }
        if (best_u >= 0) copies[static_cast<size_t>(v)].push_back({u, v, best_u, best_v});
      }
    }
  });
  for (const auto& row : copies) {
    for (const Copy& c : row) {
      s->Set(c.u, c.v, s->disparity.at<float>(c.from_v, c.from_u),
             static_cast<float>(c.from_u - c.u) + s->OffsetU(c.from_u, c.from_v),
             static_cast<float>(c.from_v - c.v) + s->OffsetV(c.from_u, c.from_v),
             s->flags.at<uint8_t>(c.from_v, c.from_u));
    }
  }
}

// A crack pixel's fill: the mean of its neighbours' points.
struct CrackFill {
  int u, v;
  float d, du, dv;
  uint8_t flags;
};

// The fills of the crack pixels of rows [row_begin, row_end) (rows 1 .. H - 2), appended to
// `out`; `empty_columns` is a work row of W ints.
EPMAP_HOT_LOOP void FindCrackFills(const Splat& splat, float max_step, int row_begin, int row_end,
                                   std::vector<int>* empty_columns, std::vector<CrackFill>* out) {
  const Splat* s = &splat;
  const int W = s->W;
  std::vector<int>& empty = *empty_columns;
  for (int v = row_begin; v < row_end; ++v) {
    const float* d_mid = s->disparity.ptr<float>(v);
    // The empty pixels of the row, listed without branches first: they lie scattered, and a
    // branch per pixel was mispredicted at every one of them.
    int n_empty = 0;
    for (int u = 1; u + 1 < W; ++u) {
      empty[static_cast<size_t>(n_empty)] = u;
      n_empty += d_mid[u] > 0 ? 0 : 1;
    }
    for (int e = 0; e < n_empty; ++e) {
      const int u = empty[static_cast<size_t>(e)];
      // The mean of the neighbours' points, as disparity and position (within one surface,
      // d_max - d_min <= max_step, the same as the mean 3-D point to first order).
      float sd = 0, su = 0, sv = 0, d_min = 1e30F, d_max = -1e30F;
      int n = 0, n_measured = 0;
      uint8_t dynamic = 0;
      for (int dv = -1; dv <= 1; ++dv) {
        const float* d_row = s->disparity.ptr<float>(v + dv);
        const int16_t* o_row = s->offsets.ptr<int16_t>(v + dv);
        const uint8_t* f_row = s->flags.ptr<uint8_t>(v + dv);
        for (int du = -1; du <= 1; ++du) {
          const float d = d_row[u + du];
          if (!(d > 0)) continue;
          d_min = std::min(d_min, d);
          d_max = std::max(d_max, d);
          sd += d;
          su += static_cast<float>(du * kOffsetScale + o_row[2 * (u + du)]);
          sv += static_cast<float>(dv * kOffsetScale + o_row[2 * (u + du) + 1]);
          ++n;
          n_measured += (f_row[u + du] & kMeasured) ? 1 : 0;
          dynamic |= f_row[u + du] & (kDynamic | kUnseen);
        }
      }
      if (n >= 3 && d_max - d_min <= max_step) {
        const float inv = 1.0F / static_cast<float>(n);
        constexpr float kToPx = 1.0F / kOffsetScale;
        out->push_back({u, v, sd * inv, su * inv * kToPx, sv * inv * kToPx,
                        static_cast<uint8_t>((2 * n_measured > n ? kMeasured : 0) | dynamic)});
      }
    }
  }
}

void FillCracks(const PredictionParams& params, Splat* s) {
  const float max_step = static_cast<float>(params.crack_max_step_px);
  const int H = s->H, W = s->W;
  // The fills of each chunk of rows, kept by the chunk's first row (one vector per chunk, not
  // per row: a vector per row grew by reallocation thousands of times a frame).
  std::vector<std::vector<CrackFill>> fills(static_cast<size_t>(H));
  std::vector<cv::Range> chunks(static_cast<size_t>(H));
  cv::parallel_for_(cv::Range(1, H - 1), [&](const cv::Range& rows) {
    std::vector<int> empty(static_cast<size_t>(W));
    std::vector<CrackFill>& out = fills[static_cast<size_t>(rows.start)];
    chunks[static_cast<size_t>(rows.start)] = rows;
    out.reserve(static_cast<size_t>(rows.end - rows.start) * static_cast<size_t>(W) / 8);
    FindCrackFills(*s, max_step, rows.start, rows.end, &empty, &out);
  });
  // Written once every fill is known (a fill must not feed its neighbours'); each writes its
  // own pixel, so the chunks are written in parallel too.
  std::vector<size_t> firsts;
  for (size_t r = 0; r < chunks.size(); ++r) {
    if (chunks[r].end > chunks[r].start) firsts.push_back(r);
  }
  cv::parallel_for_(cv::Range(0, static_cast<int>(firsts.size())), [&](const cv::Range& range) {
    for (int k = range.start; k < range.end; ++k) {
      for (const CrackFill& f : fills[firsts[static_cast<size_t>(k)]]) {
        s->Set(f.u, f.v, f.d, f.du, f.dv, f.flags);
      }
    }
  });
}

// One row of FillSmallHoles: each run of small-hole pixels is filled from the points beside it.
template <typename RunStays>
void FillSmallHolesRow(int v, const cv::Mat& small, const RunStays& near_border_run_stays,
                       Splat* s) {
  constexpr float kSameSurfacePx = 2.0F;
  const int W = s->W;
  const uint8_t* sm = small.ptr<uint8_t>(v);
  float* disp = s->disparity.ptr<float>(v);
  uint8_t* f = s->flags.ptr<uint8_t>(v);
  int u = 0;
  while (u < W) {
    // Most of a row has no small hole: skip it eight bytes at a time.
    if (u + 8 <= W) {
      uint64_t word;
      std::memcpy(&word, sm + u, sizeof(word));
      if (word == 0) {
        u += 8;
        continue;
      }
    }
    if (!sm[u]) {
      ++u;
      continue;
    }
    // A run of small-hole pixels on this row, [begin, end), and the points beside it (a run
    // may also end at a large hole).
    const int begin = u;
    while (u < W && sm[u]) ++u;
    const int end = u;
    if (near_border_run_stays(v, begin, end)) continue;
    const float d_left = begin > 0 ? disp[begin - 1] : 0.0F;
    const float d_right = end < W ? disp[end] : 0.0F;
    if (!(d_left > 0) && !(d_right > 0)) continue;  // between holes: stays a hole
    const uint8_t f_left = d_left > 0 ? f[begin - 1] : 0, f_right = d_right > 0 ? f[end] : 0;
    const bool one_surface =
        d_left > 0 && d_right > 0 && std::abs(d_left - d_right) <= kSameSurfacePx;
    for (int i = begin; i < end; ++i) {
      if (one_surface) {
        const float t = static_cast<float>(i - begin + 1) / static_cast<float>(end - begin + 1);
        s->SetOnRay(i, v, d_left * (1 - t) + d_right * t,
                    static_cast<uint8_t>((f_left & f_right & kMeasured) |
                                         ((f_left | f_right) & (kDynamic | kUnseen))));
      } else {
        const bool take_left = d_left > 0 && (!(d_right > 0) || d_left < d_right);
        // A guess at what was uncovered: not a measurement.
        s->SetOnRay(i, v, take_left ? d_left : d_right,
                    static_cast<uint8_t>((f_left | f_right) & (kDynamic | kUnseen)));
      }
    }
  }
}

// Small holes (at most max_hole_fill_px wide and tall, found as what an opening by a square of
// that size removes from the hole mask, away from the image border: wider cracks, slivers
// uncovered behind an edge) are filled along their row from the points on either side:
// linearly between two ends of one surface (within 2 px of disparity), else with the farther
// end (what an edge uncovers is background). The fill counts as measured only when it
// interpolates one measured surface. Large holes and the newly visible border stay holes: only
// SGBM can tell what is there.
void FillSmallHoles(const PredictionParams& params, Splat* s) {
  const int W = s->W, H = s->H, n = params.max_hole_fill_px;
  const cv::Mat holes = s->disparity <= 0;
  cv::Mat large;
  cv::morphologyEx(holes, large, cv::MORPH_OPEN,
                   cv::getStructuringElement(cv::MORPH_RECT, cv::Size(n + 1, n + 1)));
  // Small holes: holes the opening removed (holes - large, large being inside holes).
  cv::Mat small;
  cv::subtract(holes, large, small);
  // Holes near the border may be the start of a newly visible strip: SGBM's. Near the border
  // (within `margin`), a run is filled only if it is short (at most n), does not reach the left
  // or right edge, and no pixel of it is joined to the top or bottom edge by a column of holes.
  // (Excluding every hole near the border cost an SGBM box, padded by the whole search range,
  // for each crack of a pixel or two along the right edge: ~1-3% of the frame's SGBM work.)
  const int margin = std::min({n + 1, W / 2, H / 2});
  // edge_joined row r (r < margin): top rows; row margin + r: the bottom rows, from the bottom.
  cv::Mat edge_joined(2 * margin, W, CV_8U);
  for (int r = 0; r < margin; ++r) {
    const uint8_t* top = holes.ptr<uint8_t>(r);
    const uint8_t* bottom = holes.ptr<uint8_t>(H - 1 - r);
    const uint8_t* top_prev = r > 0 ? edge_joined.ptr<uint8_t>(r - 1) : nullptr;
    const uint8_t* bottom_prev = r > 0 ? edge_joined.ptr<uint8_t>(margin + r - 1) : nullptr;
    uint8_t* top_out = edge_joined.ptr<uint8_t>(r);
    uint8_t* bottom_out = edge_joined.ptr<uint8_t>(margin + r);
    for (int u = 0; u < W; ++u) {
      top_out[u] = top[u] && (!top_prev || top_prev[u]) ? 1 : 0;
      bottom_out[u] = bottom[u] && (!bottom_prev || bottom_prev[u]) ? 1 : 0;
    }
  }
  const auto near_border_run_stays = [&](int v, int begin, int end) {
    const bool near_top = v < margin, near_bottom = v >= H - margin;
    if (!near_top && !near_bottom && begin >= margin && end <= W - margin) return false;
    if (end - begin > n || begin == 0 || end == W) return true;
    const uint8_t* joined = near_top      ? edge_joined.ptr<uint8_t>(v)
                            : near_bottom ? edge_joined.ptr<uint8_t>(margin + (H - 1 - v))
                                          : nullptr;
    if (joined) {
      for (int i = begin; i < end; ++i) {
        if (joined[i]) return true;
      }
    }
    return false;
  };
  // Rows are independent (a run is filled from its own row): two threads share them.
  cv::parallel_for_(cv::Range(0, H), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v)
      FillSmallHolesRow(v, small, near_border_run_stays, s);
  });
}

// The moved point that lands on pixel (ui, vi) at sub-pixel offset (du, dv) from its centre.
struct Landing {
  int ui, vi;
  float d, du, dv;
  uint8_t flags;
};

// The motion and camera of one prediction, as plain floats (copied into registers by the loops
// below: through references the compiler would reload them after every store).
struct SplatMotion {
  float r[9], t[3];
  float fx, fy, cx, cy, fb, min_depth, max_step;
  int W, H;
};

// Where the points land: one frame's offsets (2 x int16), flags and disparities (0 = empty).
struct SplatTarget {
  int16_t* offsets;
  uint8_t* flags;
  float* disparity;
};

// Writes a point if it beats the pixel's current one: between two surfaces the nearer point,
// on one surface the point nearer to the pixel centre (compared on the stored offsets). Scalar
// arguments, not a Landing: built in memory, the struct kept the hot loop's values out of
// registers.
inline void LandAt(const SplatMotion& m, const SplatTarget& t, int ui, int vi, float d, float du,
                   float dv, uint8_t flags) {
  const size_t idx = static_cast<size_t>(vi) * static_cast<size_t>(m.W) + static_cast<size_t>(ui);
  const float d_old = t.disparity[idx];  // 0 when empty
  int16_t* dst = t.offsets + 2 * idx;
  const int16_t ou = Splat::ToOffset(du), ov = Splat::ToOffset(dv);
  if (d_old != 0.0F) {
    if (std::abs(d - d_old) > m.max_step) {
      if (d < d_old) return;  // behind the current surface
    } else if (ou * ou + ov * ov >= dst[0] * dst[0] + dst[1] * dst[1]) {
      return;
    }
  }
  dst[0] = ou;
  dst[1] = ov;
  t.flags[idx] = flags;
  t.disparity[idx] = d;
}

inline void Land(const SplatMotion& m, const Landing& l, const SplatTarget& t) {
  LandAt(m, t, l.ui, l.vi, l.d, l.du, l.dv, l.flags);
}

// One row of moved points, projected: disparity and sub-pixel position in the new image
// (u = -1 where the point does not land: none, behind the camera, outside the image). Kept
// apart from the landing, which is sequential, so that this loop vectorises.
struct RowProjection {
  std::vector<float> ou, ov, d, u, v;
  explicit RowProjection(int width)
      : ou(static_cast<size_t>(width)), ov(ou.size()), d(ou.size()), u(ou.size()), v(ou.size()) {}

  // Row `row` of the previous map: its disparities and offsets.
  void Project(int row, const float* disparity, const int16_t* offsets, const SplatMotion& m) {
    const int n = static_cast<int>(ou.size());
    for (int i = 0; i < n; ++i) {  // one array per coordinate
      ou[static_cast<size_t>(i)] = static_cast<float>(offsets[2 * i]);
      ov[static_cast<size_t>(i)] = static_cast<float>(offsets[2 * i + 1]);
    }
    ProjectArrays(n, row, m, disparity, ou.data(), ov.data(), d.data(), u.data(), v.data());
  }

  // X = z ((u + ou - cx) / fx, (v + ov - cy) / fy, 1) with z = fb / d_k; X' = R X + t. Divided
  // by z: X' / z = R (a, b, 1) + t w with w = 1 / z = d_k / fb, so that one division per point
  // (1 / (X'/z)_z) gives the new position and d' = fb / z' = fb w / (X'/z)_z.
  // __restrict: the arrays never overlap (without it the compiler must assume they might and
  // gives up vectorising).
  static void ProjectArrays(int n, int row, const SplatMotion& m, const float* __restrict dk,
                            const float* __restrict ous, const float* __restrict ovs,
                            float* __restrict ds, float* __restrict us, float* __restrict vs) {
    const float r00 = m.r[0], r01 = m.r[1], r02 = m.r[2];
    const float r10 = m.r[3], r11 = m.r[4], r12 = m.r[5];
    const float r20 = m.r[6], r21 = m.r[7], r22 = m.r[8];
    const float tx = m.t[0], ty = m.t[1], tz = m.t[2];
    const float fx = m.fx, fy = m.fy, cx = m.cx, cy = m.cy, fb = m.fb, min_depth = m.min_depth;
    const float inv_fx = 1.0F / fx, inv_fb = 1.0F / fb, to_px = 1.0F / kOffsetScale;
    const float b0 = (static_cast<float>(row) - cy) / fy, b_per_unit = to_px / fy;
    const float u_max = static_cast<float>(m.W) - 0.5F, v_max = static_cast<float>(m.H) - 0.5F;
    constexpr float kInf = std::numeric_limits<float>::infinity();
    for (int i = 0; i < n; ++i) {
      const float a = (static_cast<float>(i) + ous[i] * to_px - cx) * inv_fx;
      const float b = b0 + ovs[i] * b_per_unit;
      const float w = dk[i] * inv_fb;
      const float x = r00 * a + r01 * b + r02 + tx * w;
      const float y = r10 * a + r11 * b + r12 + ty * w;
      const float z = r20 * a + r21 * b + r22 + tz * w;
      const float inv_z = 1.0F / z;
      const float u1 = fx * x * inv_z + cx, v1 = fy * y * inv_z + cy;
      // No point here (NaN or 0), an infinite disparity, behind the new camera (z' = z / w
      // below min_depth), or outside the image (all comparisons are false for NaN); & rather
      // than &&: no branches in the loop.
      const bool ok = (dk[i] > 0) & (dk[i] < kInf) & (z > min_depth * w) & (u1 > -0.5F) &
                      (v1 > -0.5F) & (u1 < u_max) & (v1 < v_max);
      ds[i] = fb * w * inv_z;
      us[i] = ok ? u1 : -1.0F;
      vs[i] = ok ? v1 : 0.0F;
    }
  }
};

// Moves the points of rows [row_begin, row_end) of the previous map and lands those whose
// pixel lies in the same rows; the others are returned in `crossers` (another thread owns
// their rows). Per row, the projection runs first over the whole row into small arrays (a loop
// the compiler vectorises), then the landings, which depend on each other, one by one.
EPMAP_HOT_LOOP void SplatRows(const MapState& previous, const SplatMotion& motion, int row_begin,
                              int row_end, const SplatTarget& target,
                              std::vector<Landing>* crossers) {
  const int W = motion.W;
  RowProjection row(W);
  for (int v = row_begin; v < row_end; ++v) {
    const uint8_t* m = previous.flags.ptr<uint8_t>(v);
    row.Project(v, previous.disparity.ptr<float>(v), previous.offsets.ptr<int16_t>(v), motion);
    const float *ds = row.d.data(), *us = row.u.data(), *vs = row.v.data();
    for (int u = 0; u < W; ++u) {
      const float u1 = us[u], v1 = vs[u];
      if (u1 == -1.0F) continue;
      const int ui = static_cast<int>(u1 + 0.5F), vi = static_cast<int>(v1 + 0.5F);
      const float du = u1 - static_cast<float>(ui), dv = v1 - static_cast<float>(vi);
      if (vi >= row_begin && vi < row_end) {
        LandAt(motion, target, ui, vi, ds[u], du, dv, m[u]);
      } else {
        crossers->push_back({ui, vi, ds[u], du, dv, m[u]});
      }
    }
  }
}

// Rows [row_begin, row_end) of the full-size outputs from the splat: the geometry, D_- (NaN
// where the point is not a measurement), the holes; empty pixels get no flags and no offsets.
// Counts the holes, and the points whose arithmetic broke down (non-finite: made holes).
EPMAP_HOT_LOOP void WriteOutputRows(int row_begin, int row_end, Splat* s, Prediction* out,
                                    int* broken_count, int* hole_count) {
  int broken = 0, holes = 0;  // locals: the byte stores below could alias the counters
  for (int v = row_begin; v < row_end; ++v) {
    int16_t* offsets = s->offsets.ptr<int16_t>(v);
    const float* d_splat = s->disparity.ptr<float>(v);
    float* disp = out->disparity.ptr<float>(v);
    float* geo = out->geometry.ptr<float>(v);
    uint8_t* flags = s->flags.ptr<uint8_t>(v);
    uint8_t* hole = out->holes.ptr<uint8_t>(v);
    for (int u = 0; u < s->W; ++u) {
      // A point that overflowed has d = 0 or a non-finite d: checking d suffices.
      const float d = d_splat[u];
      const bool ok = d > 0 && d < std::numeric_limits<float>::infinity();
      if (ok) {
        geo[u] = d;
        disp[u] = (flags[u] & kMeasured) ? d : kNaN;
        hole[u] = 0;
      } else {
        if (d > 0) ++broken;  // a point was there but the arithmetic broke down
        ++holes;
        geo[u] = kNaN;
        disp[u] = kNaN;
        hole[u] = 255;
        flags[u] = 0;
        offsets[2 * u] = offsets[2 * u + 1] = 0;
      }
    }
  }
  *broken_count += broken;
  *hole_count += holes;
}

// Where the points of one row of the comparison grid lie in frame k (Sec. IV-A, backwards):
// each grid pixel centre (u, v) = (j * step, v) is back-projected at its point's depth
// z = fb / d, X' = z ray(u, v), moved back, X = R^T (X' - t), and projected, q = pi(X).
// q = (-1, -1) where there is no point (NaN disparity), the depth is degenerate or q falls
// outside frame k. __restrict and no branches: the loop vectorises.
EPMAP_HOT_LOOP void ProjectGridRowIntoPrevious(const SplatMotion& m,
                                               const float* __restrict geometry_row, int v,
                                               int step, int n, float* __restrict qxs,
                                               float* __restrict qys) {
  const float r00 = m.r[0], r01 = m.r[1], r02 = m.r[2];
  const float r10 = m.r[3], r11 = m.r[4], r12 = m.r[5];
  const float r20 = m.r[6], r21 = m.r[7], r22 = m.r[8];
  const float tx = m.t[0], ty = m.t[1], tz = m.t[2];
  const float fx = m.fx, fy = m.fy, cx = m.cx, cy = m.cy, fb = m.fb, min_depth = m.min_depth;
  const float inv_fx = 1.0F / fx;
  const float w_last = static_cast<float>(m.W - 1), h_last = static_cast<float>(m.H - 1);
  const float ray_y = (static_cast<float>(v) - cy) / fy;
  for (int j = 0; j < n; ++j) {
    const float z = fb / geometry_row[j * step];                             // NaN at holes
    const float ax = (static_cast<float>(j * step) - cx) * inv_fx * z - tx;  // X' - t
    const float ay = ray_y * z - ty;
    const float az = z - tz;
    const float x = r00 * ax + r10 * ay + r20 * az;  // R^T (X' - t)
    const float y = r01 * ax + r11 * ay + r21 * az;
    const float zk = r02 * ax + r12 * ay + r22 * az;
    const float inv_zk = 1.0F / zk;
    const float qx = fx * x * inv_zk + cx, qy = fy * y * inv_zk + cy;
    // All comparisons are false for NaN; & rather than &&: no branches.
    const bool ok = (z > min_depth) & (zk > min_depth) & (qx >= 0) & (qy >= 0) & (qx <= w_last) &
                    (qy <= h_last);
    qxs[j] = ok ? qx : -1.0F;
    qys[j] = ok ? qy : -1.0F;
  }
}

// L^k (full resolution, 8-bit) at q and C^k (comparison grid) at q / step, both bilinear (C^k
// with its edge replicated), for one grid row; 0 and not valid where q = -1. A non-finite C^k
// value would spread through the sample: such samples are 0 (no history).
EPMAP_HOT_LOOP void SampleGridRow(const cv::Mat& image_k, const cv::Mat& history_k, float inv_step,
                                  const float* qxs, const float* qys, int n, float* lum, float* acc,
                                  uint8_t* valid) {
  const int W = image_k.cols, H = image_k.rows;
  const int grid_w_last = history_k.cols - 1, grid_h_last = history_k.rows - 1;
  for (int j = 0; j < n; ++j) {
    const float qx = qxs[j], qy = qys[j];
    if (qx < 0) {
      valid[j] = 0;
      lum[j] = 0.0F;
      acc[j] = 0.0F;
      continue;
    }
    valid[j] = 255;
    {  // L^k at q
      const int x0 = static_cast<int>(qx), y0 = static_cast<int>(qy);
      const int x1 = std::min(x0 + 1, W - 1), y1 = std::min(y0 + 1, H - 1);
      const float a = qx - static_cast<float>(x0), b = qy - static_cast<float>(y0);
      const uint8_t* r0 = image_k.ptr<uint8_t>(y0);
      const uint8_t* r1 = image_k.ptr<uint8_t>(y1);
      const float top = static_cast<float>(r0[x0]) + a * static_cast<float>(r0[x1] - r0[x0]);
      const float bottom = static_cast<float>(r1[x0]) + a * static_cast<float>(r1[x1] - r1[x0]);
      lum[j] = top + b * (bottom - top);
    }
    {  // C^k at q / step
      const float gx = qx * inv_step, gy = qy * inv_step;
      const int x0 = std::min(static_cast<int>(gx), grid_w_last);
      const int y0 = std::min(static_cast<int>(gy), grid_h_last);
      const int x1 = std::min(x0 + 1, grid_w_last), y1 = std::min(y0 + 1, grid_h_last);
      const float a = gx - static_cast<float>(x0), b = gy - static_cast<float>(y0);
      const float* r0 = history_k.ptr<float>(y0);
      const float* r1 = history_k.ptr<float>(y1);
      const float top = r0[x0] * (1.0F - a) + r0[x1] * a;
      const float bottom = r1[x0] * (1.0F - a) + r1[x1] * a;
      const float c = top * (1.0F - b) + bottom * b;
      acc[j] = std::isfinite(c) ? c : 0.0F;
    }
  }
}
}  // namespace

void PredictionParams::Validate() const {
  if (image_step != 1 && image_step != 2) {
    throw std::invalid_argument("EP generator: image_step must be 1 or 2");
  }
  if (!(splat_radius_px >= 0.5 && splat_radius_px < 1.0)) {
    throw std::invalid_argument("EP generator: splat_radius_px must be in [0.5, 1)");
  }
  if (!(crack_max_step_px >= 0) || !(min_depth_m > 0) || max_hole_fill_px < 0) {
    throw std::invalid_argument(
        "EP generator: crack_max_step_px >= 0, min_depth_m > 0, max_hole_fill_px >= 0");
  }
}

cv::Size ComparisonGrid(const stereo::RectifiedGeometry& camera, int image_step) {
  return {(camera.width + image_step - 1) / image_step,
          (camera.height + image_step - 1) / image_step};
}

void SetPointsFromDisparity(const cv::Mat& disparity, MapState* state, double min_disparity_px) {
  if (disparity.type() != CV_32FC1) {
    throw std::invalid_argument("points from disparity: CV_32FC1 expected");
  }
  const float min_d = static_cast<float>(min_disparity_px);
  state->disparity.create(disparity.size(), CV_32FC1);
  for (int v = 0; v < disparity.rows; ++v) {
    const float* d = disparity.ptr<float>(v);
    float* out = state->disparity.ptr<float>(v);
    for (int u = 0; u < disparity.cols; ++u) {
      out[u] = d[u] > min_d && std::isfinite(d[u]) ? d[u] : kNaN;
    }
  }
  state->offsets = cv::Mat::zeros(disparity.size(), CV_16SC2);
}

Prediction Predict(const MapState& previous, const Eigen::Isometry3d& T_cur_prev,
                   const stereo::RectifiedGeometry& camera, const PredictionParams& params,
                   PredictionScratch* scratch) {
  CheckInputs(previous, camera, T_cur_prev, params);
  PredictionScratch local;
  PredictionScratch& mem = scratch ? *scratch : local;
  // Of the two offset buffers, the one the previous state does not use.
  cv::Mat& offsets_buffer = mem.offsets[0].data && mem.offsets[0].data == previous.offsets.data
                                ? mem.offsets[1]
                                : mem.offsets[0];
  const int W = camera.width, H = camera.height;
  Splat s;
  s.W = W;
  s.H = H;
  const float fx = static_cast<float>(camera.fx), fy = static_cast<float>(camera.fy);
  const float cx = static_cast<float>(camera.cx), cy = static_cast<float>(camera.cy);
  const float fb = static_cast<float>(camera.fx * camera.baseline_m);  // z = fb / d
  const Eigen::Matrix3f R = T_cur_prev.linear().cast<float>();
  const float r00 = R(0, 0), r01 = R(0, 1), r02 = R(0, 2);
  const float r10 = R(1, 0), r11 = R(1, 1), r12 = R(1, 2);
  const float r20 = R(2, 0), r21 = R(2, 1), r22 = R(2, 2);
  const float tx = static_cast<float>(T_cur_prev.translation().x());
  const float ty = static_cast<float>(T_cur_prev.translation().y());
  const float tz = static_cast<float>(T_cur_prev.translation().z());
  const float min_depth = static_cast<float>(params.min_depth_m);
  const float max_step = static_cast<float>(params.crack_max_step_px);

  // 1. p_D (Sec. IV-B): every point X of frame k becomes X' = R X + t in frame k+1 and lands on
  //    the pixel nearest to its projection. Between two surfaces the nearer point wins
  //    (z-buffer); on one surface, the point nearer to the pixel centre (which keeps one point
  //    per pixel where the lattice of exact points is slightly irregular).
  //    Two threads share the work: each moves the points of one half of the rows and writes
  //    those that land in its own half of the target rows; the few that cross the middle are
  //    written afterwards, in order (the camera moves little between frames).
  //    A pixel is empty while its disparity is 0; its point is then never read.
  offsets_buffer.create(H, W, CV_16SC2);
  mem.flags.create(H, W, CV_8U);
  mem.splat_disparity.create(H, W, CV_32F);
  s.offsets = offsets_buffer;
  s.flags = mem.flags;                // read only where a point landed; cleared at holes below
  s.disparity = mem.splat_disparity;  // cleared by each thread for its own rows, below
  SplatTarget target;
  target.offsets = s.offsets.ptr<int16_t>(0);  // all allocated whole: continuous
  target.flags = s.flags.ptr<uint8_t>(0);
  target.disparity = s.disparity.ptr<float>(0);
  const SplatMotion motion{{r00, r01, r02, r10, r11, r12, r20, r21, r22},
                           {tx, ty, tz},
                           fx,
                           fy,
                           cx,
                           cy,
                           fb,
                           min_depth,
                           max_step,
                           W,
                           H};
  const Clock::time_point t_splat = Clock::now();
  const int halves = H >= 64 ? 2 : 1;
  std::vector<std::vector<Landing>> crossing(static_cast<size_t>(halves));
  cv::parallel_for_(cv::Range(0, halves), [&](const cv::Range& range) {
    for (int half = range.start; half < range.end; ++half) {
      const int row_begin = half * H / halves, row_end = (half + 1) * H / halves;
      s.disparity.rowRange(row_begin, row_end).setTo(0);
      SplatRows(previous, motion, row_begin, row_end, target, &crossing[static_cast<size_t>(half)]);
    }
  });
  for (const auto& crossers : crossing) {
    for (const Landing& l : crossers) Land(motion, l, target);
  }
  // ... and an empty pixel takes the best point held by a neighbour whose projection lies
  // within splat_radius_px of its own centre (a footprint of 1.5 px).
  const Clock::time_point t_fill = Clock::now();
  if (params.splat_radius_px > 0.5) ExtendFootprints(params, &s);
  FillCracks(params, &s);
  if (params.max_hole_fill_px > 0) FillSmallHoles(params, &s);

  // The predicted disparity and the holes at full resolution and, from them, L_- and C_- on the
  // comparison grid: one pass over the rows (a grid row needs only its own image row's
  // geometry, written just before, still in cache).
  // 2. p(L^k; T^{k+1}, D_-^{k+1}) and p(C^k; ...) (Sec. IV-A) on the comparison grid: each of
  //    its pixel centres is back-projected at its point's depth into frame k
  //    (ProjectGridRowIntoPrevious), where L^k and C^k are interpolated (SampleGridRow).
  const Clock::time_point t_output = Clock::now();
  Prediction out;
  // D_- gets a buffer of its own each frame: the caller makes it the frame's map.
  out.disparity.create(H, W, CV_32F);
  mem.geometry.create(H, W, CV_32F);
  out.geometry = mem.geometry;
  out.holes.create(H, W, CV_8U);
  const int step = params.image_step;
  const cv::Size grid = ComparisonGrid(camera, step);
  out.image.create(grid, CV_32F);
  out.accumulated.create(grid, CV_32F);
  out.image_valid.create(grid, CV_8U);
  const float inv_step = 1.0F / static_cast<float>(step);
  const cv::Mat& image_k = previous.image;
  const cv::Mat& history_k = previous.accumulated;
  std::atomic<int> non_finite{0}, hole_count{0};
  cv::parallel_for_(cv::Range(0, grid.height), [&](const cv::Range& rows) {
    int broken = 0, holes = 0;
    WriteOutputRows(rows.start * step, std::min(rows.end * step, H), &s, &out, &broken, &holes);
    non_finite += broken;
    hole_count += holes;
    // Per row, where each grid pixel's point lands in frame k (a loop the compiler vectorises:
    // no branches, plain arrays), then the two bilinear samples there (gathers, one by one).
    std::vector<float> qxs(static_cast<size_t>(grid.width)), qys(qxs.size());
    for (int i = rows.start; i < rows.end; ++i) {
      ProjectGridRowIntoPrevious(motion, out.geometry.ptr<float>(i * step), i * step, step,
                                 grid.width, qxs.data(), qys.data());
      SampleGridRow(image_k, history_k, inv_step, qxs.data(), qys.data(), grid.width,
                    out.image.ptr<float>(i), out.accumulated.ptr<float>(i),
                    out.image_valid.ptr<uint8_t>(i));
    }
  });
  out.non_finite_rejected = non_finite;
  out.hole_pixels = hole_count;
  out.offsets = s.offsets;
  out.flags = s.flags;
  out.timings.splat_ms = MsBetween(t_splat, t_fill);
  out.timings.fill_ms = MsBetween(t_fill, t_output);
  out.timings.output_ms = MsBetween(t_output, Clock::now());
  return out;
}

}  // namespace epmap::ep
