#include "perception/occupancy/layered_grid.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace epmap::occupancy {

void GridParams::Validate() const {
  if (!(resolution_m > 0) || !std::isfinite(resolution_m)) {
    throw std::invalid_argument("occupancy grid: resolution_m must be positive and finite");
  }
  if (layer_bounds_m.size() < 2) {
    throw std::invalid_argument("occupancy grid: layer_bounds_m needs at least two heights");
  }
  for (size_t i = 1; i < layer_bounds_m.size(); ++i) {
    if (!(layer_bounds_m[i] > layer_bounds_m[i - 1])) {
      throw std::invalid_argument("occupancy grid: layer_bounds_m must increase strictly");
    }
  }
  if (!(growth_margin_m >= 0)) {
    throw std::invalid_argument("occupancy grid: growth_margin_m must be >= 0");
  }
}

void MeasurementParams::Validate() const {
  const auto unit = [](double v, const char* name) {
    if (!(v >= 0 && v <= 1)) {
      throw std::invalid_argument(std::string("occupancy measurement: ") + name +
                                  " must be in [0, 1]");
    }
  };
  unit(empty_evidence, "empty_evidence");
  unit(occupied_evidence, "occupied_evidence");
  unit(confidence_evidence, "confidence_evidence");
  if (!(frequency_prior > 0) || !std::isfinite(frequency_prior)) {
    throw std::invalid_argument("occupancy measurement: frequency_prior must be > 0");
  }
  if (!(empty_gap_sigmas >= 0) || !std::isfinite(empty_gap_sigmas)) {
    throw std::invalid_argument("occupancy measurement: empty_gap_sigmas must be >= 0");
  }
  if (!(empty_gap_min_cells >= 0) || !std::isfinite(empty_gap_min_cells)) {
    throw std::invalid_argument("occupancy measurement: empty_gap_min_cells must be >= 0");
  }
  if (!(occupied_depth_m >= 0) || !std::isfinite(occupied_depth_m)) {
    throw std::invalid_argument("occupancy measurement: occupied_depth_m must be >= 0 and finite");
  }
  if (!(max_range_m > 0)) {
    throw std::invalid_argument("occupancy measurement: max_range_m must be > 0");
  }
}

namespace {

// Fuzzy union of a membership with new evidence (probabilistic sum).
inline void Union(float& mu, double evidence) {
  mu = static_cast<float>(mu + evidence - mu * evidence);
}

// Membership::kRayFrequency: the memberships from the cell's hit and pass weights.
inline void SetFrequencies(float hits, float passes, float prior, float& occupied, float& empty) {
  const float total = hits + passes + prior;
  occupied = hits / total;
  empty = passes / total;
}

// Amanatides-Woo: calls visit(ix, iy, t_in, t_out) for each lattice cell the segment from a
// to b (in cell units) crosses, in order, with the segment's parameters where it enters and
// leaves the cell (0..1), from a's cell to b's, until visit returns false.
template <typename Visit>
void WalkCells(const Eigen::Vector2d& a, const Eigen::Vector2d& b, Visit&& visit) {
  int64_t ix = static_cast<int64_t>(std::floor(a.x())),
          iy = static_cast<int64_t>(std::floor(a.y()));
  const int64_t ex = static_cast<int64_t>(std::floor(b.x())),
                ey = static_cast<int64_t>(std::floor(b.y()));
  const double dx = b.x() - a.x(), dy = b.y() - a.y();
  const int step_x = dx > 0 ? 1 : -1, step_y = dy > 0 ? 1 : -1;
  const double inf = std::numeric_limits<double>::infinity();
  const double t_delta_x = dx != 0 ? 1.0 / std::abs(dx) : inf;
  const double t_delta_y = dy != 0 ? 1.0 / std::abs(dy) : inf;
  double t_max_x = dx != 0 ? (static_cast<double>(ix + (step_x > 0 ? 1 : 0)) - a.x()) / dx : inf;
  double t_max_y = dy != 0 ? (static_cast<double>(iy + (step_y > 0 ? 1 : 0)) - a.y()) / dy : inf;
  double t_in = 0;
  while (t_in < 1.0) {
    const double t_out = std::min({t_max_x, t_max_y, 1.0});
    if (!visit(ix, iy, t_in, t_out) || (ix == ex && iy == ey)) return;
    if (t_max_x < t_max_y) {
      ix += step_x;
      t_max_x += t_delta_x;
    } else {
      iy += step_y;
      t_max_y += t_delta_y;
    }
    t_in = t_out;
  }
}

// The bytes of one cell, as GridExport describes them.
void PutCell(const Cell& cell, double unknown_below, uint8_t* occupancy, uint8_t* confidence) {
  *confidence = static_cast<uint8_t>(std::lround(255.0 * std::clamp(cell.confidence, 0.0F, 1.0F)));
  if (cell.confidence < unknown_below) {
    *occupancy = GridExport::kUnknown;
    return;
  }
  const double occ = std::clamp(50.0 + 50.0 * (cell.occupied - cell.empty), 0.0, 100.0);
  *occupancy = static_cast<uint8_t>(std::lround(occ));
}

}  // namespace

LayeredGrid::LayeredGrid(const GridParams& params) : params_(params) {
  params_.Validate();
  layers_ = std::make_shared<std::vector<Layer>>(static_cast<size_t>(layer_count()));
}

LayeredGrid LayeredGrid::DeepCopy() const {
  LayeredGrid copy = *this;
  copy.MutableLayers();  // shared with this one: copies the cells
  return copy;
}

std::vector<LayeredGrid::Layer>& LayeredGrid::MutableLayers() {
  // Every other holder of the layers is a copy that counts, and no copy of this grid is made
  // while it changes, so a count of one cannot rise before the writes. The fence orders them
  // after the last reads of copies that were dropped (their release of the count).
  if (layers_.use_count() > 1) {
    auto own = std::make_shared<std::vector<Layer>>(layers_->size());
    for (size_t l = 0; l < own->size(); ++l) {
      const Layer& from = (*layers_)[l];
      Layer& to = (*own)[l];
      to.empty = from.empty.clone();
      to.occupied = from.occupied.clone();
      to.confidence = from.confidence.clone();
      to.hits = from.hits.clone();
      to.passes = from.passes.clone();
    }
    layers_ = std::move(own);
  } else {
    std::atomic_thread_fence(std::memory_order_acquire);
  }
  return *layers_;
}

void LayeredGrid::RestorePlanes(int64_t min_ix, int64_t min_iy, int width, int height,
                                std::vector<LayerPlanes> planes) {
  const auto fail = [](const std::string& what) {
    throw std::invalid_argument("occupancy grid: saved cells do not fit: " + what);
  };
  if (planes.size() != layers_->size()) {
    fail(std::to_string(planes.size()) + " layers, the grid has " +
         std::to_string(layers_->size()));
  }
  if (width < 0 || height < 0 || (width == 0) != (height == 0)) {
    fail("size " + std::to_string(width) + " x " + std::to_string(height));
  }
  const auto check = [&](const cv::Mat& m, bool optional, bool unit, const char* name) {
    if (optional && m.empty()) return;
    if (width == 0 && m.empty()) return;
    if (m.type() != CV_32FC1 || m.cols != width || m.rows != height) {
      fail(std::string(name) + " is not CV_32FC1 of " + std::to_string(width) + " x " +
           std::to_string(height));
    }
    if (!cv::checkRange(m, true, nullptr, 0.0, unit ? 1.0 + 1e-6 : 1e30)) {
      fail(std::string(name) + (unit ? " holds values outside [0, 1]" : " holds bad weights"));
    }
  };
  for (const auto& p : planes) {
    check(p.empty, false, true, "empty");
    check(p.occupied, false, true, "occupied");
    check(p.confidence, false, true, "confidence");
    check(p.hits, true, false, "hits");
    check(p.passes, true, false, "passes");
    if (p.hits.empty() != p.passes.empty() || p.hits.empty() != planes.front().hits.empty()) {
      fail("hits and passes come together, in every layer or none");
    }
  }
  layers_ = std::make_shared<std::vector<Layer>>(std::move(planes));  // copies keep theirs
  for (auto& l : *layers_) {  // an empty grid keeps empty planes, as a new one has
    if (width == 0) l = Layer{};
    // The grid changes its cells in place when it alone holds its layers: cells that another
    // Mat still shows (planes() of another grid, say) are copied now. Freshly decoded planes,
    // moved in, are not.
    for (cv::Mat* m : {&l.empty, &l.occupied, &l.confidence, &l.hits, &l.passes}) {
      if (m->u != nullptr && m->u->refcount > 1) *m = m->clone();
    }
  }
  min_ix_ = width == 0 ? 0 : min_ix;
  min_iy_ = width == 0 ? 0 : min_iy;
  width_ = width;
  height_ = height;
}

Eigen::Vector2d LayeredGrid::origin() const {
  return {static_cast<double>(min_ix_) * params_.resolution_m,
          static_cast<double>(min_iy_) * params_.resolution_m};
}

int64_t LayeredGrid::CellX(double x) const {
  return static_cast<int64_t>(std::floor(x / params_.resolution_m));
}
int64_t LayeredGrid::CellY(double y) const {
  return static_cast<int64_t>(std::floor(y / params_.resolution_m));
}

int LayeredGrid::LayerOf(double h) const {
  const auto& b = params_.layer_bounds_m;
  if (!(h >= b.front()) || !(h < b.back())) return -1;
  for (size_t l = 0; l + 1 < b.size(); ++l) {
    if (h < b[l + 1]) return static_cast<int>(l);
  }
  return -1;
}

void LayeredGrid::CheckLayer(int layer) const {
  if (layer < 0 || layer >= layer_count()) {
    throw std::out_of_range("occupancy grid: layer " + std::to_string(layer) +
                            " does not exist (the grid has layers 0.." +
                            std::to_string(layer_count() - 1) + ")");
  }
}

void LayeredGrid::EnsureCovers(int64_t ix_lo, int64_t iy_lo, int64_t ix_hi, int64_t iy_hi) {
  if (width_ > 0 && ix_lo >= min_ix_ && iy_lo >= min_iy_ && ix_hi < min_ix_ + width_ &&
      iy_hi < min_iy_ + height_) {
    return;
  }
  const int64_t margin =
      static_cast<int64_t>(std::ceil(params_.growth_margin_m / params_.resolution_m));
  int64_t nx0 = ix_lo - margin, ny0 = iy_lo - margin;
  int64_t nx1 = ix_hi + margin, ny1 = iy_hi + margin;
  if (width_ > 0) {
    nx0 = std::min(nx0, min_ix_);
    ny0 = std::min(ny0, min_iy_);
    nx1 = std::max(nx1, min_ix_ + width_ - 1);
    ny1 = std::max(ny1, min_iy_ + height_ - 1);
  }
  const int64_t nw = nx1 - nx0 + 1, nh = ny1 - ny0 + 1;
  if (nw > 100000 || nh > 100000 || nw * nh > 400'000'000) {
    throw std::length_error("occupancy grid: growing to " + std::to_string(nw) + " x " +
                            std::to_string(nh) + " cells is beyond reason (a point far away?)");
  }
  // New planes in any case: copies that share the old ones keep them.
  auto grown_layers = std::make_shared<std::vector<Layer>>(*layers_);
  for (auto& layer : *grown_layers) {
    for (cv::Mat* m :
         {&layer.empty, &layer.occupied, &layer.confidence, &layer.hits, &layer.passes}) {
      const bool counts = m == &layer.hits || m == &layer.passes;
      if (counts && m->empty()) continue;  // allocated by the first ray-frequency point
      cv::Mat grown(static_cast<int>(nh), static_cast<int>(nw), CV_32FC1, cv::Scalar(0));
      if (width_ > 0) {
        m->copyTo(grown(cv::Rect(static_cast<int>(min_ix_ - nx0), static_cast<int>(min_iy_ - ny0),
                                 width_, height_)));
      }
      *m = grown;
    }
  }
  layers_ = std::move(grown_layers);
  min_ix_ = nx0;
  min_iy_ = ny0;
  width_ = static_cast<int>(nw);
  height_ = static_cast<int>(nh);
}

bool LayeredGrid::AddPoint(const Eigen::Vector3d& origin, const Eigen::Vector3d& point,
                           double range_sigma_m, const MeasurementParams& mp) {
  if (!origin.allFinite() || !point.allFinite() || !std::isfinite(range_sigma_m)) return false;
  const double range = (point - origin).norm();
  const Eigen::Vector2d o(origin.x(), origin.y());
  const Eigen::Vector2d p(point.x(), point.y());
  const double horizontal = (p - o).norm();
  if (range > mp.max_range_m || horizontal < 1e-6) return false;
  const double res = params_.resolution_m;
  const double sigma = std::max(range_sigma_m, 1e-6);
  const double weight = std::min(1.0, std::pow(res / sigma, mp.weight_exponent));
  const double gap = std::max(mp.empty_gap_sigmas * sigma, mp.empty_gap_min_cells * res);

  const double behind = mp.occupied_depth_m;
  const Eigen::Vector2d beyond = p + (p - o) * (behind / horizontal);
  const int64_t ex = CellX(p.x()), ey = CellY(p.y());
  const int64_t sx = CellX(o.x()), sy = CellY(o.y());
  const int64_t bx = CellX(beyond.x()), by = CellY(beyond.y());
  EnsureCovers(std::min({sx, ex, bx}), std::min({sy, ey, by}), std::max({sx, ex, bx}),
               std::max({sy, ey, by}));
  const bool frequency = mp.membership == Membership::kRayFrequency;
  std::vector<Layer>& layers = MutableLayers();
  if (frequency && layers.front().hits.empty()) {
    for (auto& layer : layers) {
      layer.hits = cv::Mat::zeros(height_, width_, CV_32FC1);
      layer.passes = cv::Mat::zeros(height_, width_, CV_32FC1);
    }
  }
  const float prior = static_cast<float>(mp.frequency_prior);

  // The cells between the head and the point, in the plane; the height of the ray inside each
  // cell picks the layer the empty evidence goes to.
  const double t_empty_end = (horizontal - gap) / horizontal;
  const float empty_k = static_cast<float>(0.5 * mp.confidence_evidence);
  WalkCells(o / res, p / res, [&](int64_t ix, int64_t iy, double t_in, double t_out) {
    if ((ix == ex && iy == ey) || t_out > t_empty_end) {
      return false;  // the rest of the ray is within the point's uncertainty
    }
    const double z = origin.z() + 0.5 * (t_in + t_out) * (point.z() - origin.z());
    const int l = LayerOf(z);
    if (l >= 0) {
      const int c = static_cast<int>(ix - min_ix_), r = static_cast<int>(iy - min_iy_);
      Layer& L = layers[static_cast<size_t>(l)];
      if (frequency) {
        float& passes = L.passes.at<float>(r, c);
        passes += static_cast<float>(weight);
        SetFrequencies(L.hits.at<float>(r, c), passes, prior, L.occupied.at<float>(r, c),
                       L.empty.at<float>(r, c));
      } else {
        Union(L.empty.at<float>(r, c), mp.empty_evidence);
      }
      Union(L.confidence.at<float>(r, c), empty_k);
    }
    return true;
  });
  const int l = LayerOf(point.z());
  if (l < 0) return true;
  Layer& L = layers[static_cast<size_t>(l)];
  const auto hit = [&](int64_t ix, int64_t iy) {
    const int c = static_cast<int>(ix - min_ix_), r = static_cast<int>(iy - min_iy_);
    if (frequency) {
      float& hits = L.hits.at<float>(r, c);
      hits += static_cast<float>(weight);
      SetFrequencies(hits, L.passes.at<float>(r, c), prior, L.occupied.at<float>(r, c),
                     L.empty.at<float>(r, c));
    } else {
      Union(L.occupied.at<float>(r, c), mp.occupied_evidence * weight);
    }
    Union(L.confidence.at<float>(r, c), mp.confidence_evidence * weight);
  };
  hit(ex, ey);
  // A point is where a surface begins; what lies just behind it along the ray is the object's
  // body (a wall's thickness), marked occupied too (at the point's height).
  if (behind > 0) {
    WalkCells(p / res, beyond / res, [&](int64_t ix, int64_t iy, double, double) {
      if (ix != ex || iy != ey) hit(ix, iy);
      return true;
    });
  }
  return true;
}

int LayeredGrid::AddSegment(const Eigen::Vector3d& origin, const Eigen::Vector3d& a,
                            const Eigen::Vector3d& b, int parts, double range_sigma_m,
                            const MeasurementParams& mp) {
  if (parts < 1) return 0;
  int added = 0;
  for (int k = 0; k < parts; ++k) {
    const double t = (k + 0.5) / parts;
    added += AddPoint(origin, a + t * (b - a), range_sigma_m, mp) ? 1 : 0;
  }
  return added;
}

int PartsForImageLength(double image_length_px, double part_length_px) {
  if (!(part_length_px > 0) || !std::isfinite(image_length_px)) return 1;
  return std::max(1, static_cast<int>(std::lround(image_length_px / part_length_px)));
}

Cell LayeredGrid::At(int layer, int64_t ix, int64_t iy) const {
  CheckLayer(layer);
  if (width_ == 0 || ix < min_ix_ || iy < min_iy_ || ix >= min_ix_ + width_ ||
      iy >= min_iy_ + height_) {
    return {};
  }
  const int c = static_cast<int>(ix - min_ix_), r = static_cast<int>(iy - min_iy_);
  const Layer& L = (*layers_)[static_cast<size_t>(layer)];
  return {L.empty.at<float>(r, c), L.occupied.at<float>(r, c), L.confidence.at<float>(r, c)};
}

Cell LayeredGrid::Combined(int64_t ix, int64_t iy, int first_layers) const {
  CheckFirstLayers(first_layers);
  return CombineLowest(ix, iy, first_layers);
}

Cell LayeredGrid::CombineLowest(int64_t ix, int64_t iy, int first_layers) const {
  Cell out;
  float max_empty = 0;
  for (int l = 0; l < first_layers; ++l) {
    const Cell c = At(l, ix, iy);
    out.occupied = std::max(out.occupied, c.occupied);
    max_empty = std::max(max_empty, c.empty);
    out.confidence = std::max(out.confidence, c.confidence);
  }
  out.empty = std::min(max_empty, 1.0F - out.occupied);
  return out;
}

void LayeredGrid::CheckFirstLayers(int first_layers) const {
  if (first_layers < 1 || first_layers > layer_count()) {
    throw std::out_of_range("occupancy grid: cannot combine the lowest " +
                            std::to_string(first_layers) + " layers (the grid has " +
                            std::to_string(layer_count()) + ")");
  }
}

int LayeredGrid::LayersBelow(double height_m) const {
  if (!std::isfinite(height_m)) return 0;
  int n = 0;
  for (int l = 0; l < layer_count(); ++l) {
    if (params_.layer_bounds_m[static_cast<size_t>(l)] < height_m) n = l + 1;
  }
  return n;
}

cv::Mat LayeredGrid::SyntheticMap() const {
  cv::Mat m(height_, width_, CV_32FC1, cv::Scalar(0));
  for (const auto& L : *layers_) {
    if (L.occupied.empty()) continue;
    cv::Mat o_and_k;
    cv::min(L.occupied, L.confidence, o_and_k);  // O_l n K_l
    cv::max(m, o_and_k, m);                      // U_l
  }
  return m;
}

void LayeredGrid::ReadRow(std::optional<int> layer, int first_layers, int r, int c0, int c1,
                          Cell* out) const {
  if (layer) {
    const Layer& L = (*layers_)[static_cast<size_t>(*layer)];
    if (L.empty.empty()) {  // a layer never allocated reads as never seen, as At() says
      for (int c = c0; c < c1; ++c) out[c - c0] = {};
      return;
    }
    const float* e = L.empty.ptr<float>(r);
    const float* o = L.occupied.ptr<float>(r);
    const float* k = L.confidence.ptr<float>(r);
    for (int c = c0; c < c1; ++c) out[c - c0] = {e[c], o[c], k[c]};
    return;
  }
  // O = max_l O_l, E = min(max_l E_l, 1 - O), K = max_l K_l (the combined map, see Combined).
  for (int c = c0; c < c1; ++c) out[c - c0] = {};
  for (int l = 0; l < first_layers; ++l) {
    const Layer& L = (*layers_)[static_cast<size_t>(l)];
    if (L.empty.empty()) continue;
    const float* e = L.empty.ptr<float>(r);
    const float* o = L.occupied.ptr<float>(r);
    const float* k = L.confidence.ptr<float>(r);
    for (int c = c0; c < c1; ++c) {
      Cell& cell = out[c - c0];
      cell.empty = std::max(cell.empty, e[c]);  // max_l E_l for now
      cell.occupied = std::max(cell.occupied, o[c]);
      cell.confidence = std::max(cell.confidence, k[c]);
    }
  }
  for (int c = c0; c < c1; ++c) {
    Cell& cell = out[c - c0];
    cell.empty = std::min(cell.empty, 1.0F - cell.occupied);
  }
}

GridExport LayeredGrid::ExportCells(std::optional<int> layer, int first_layers,
                                    double unknown_below) const {
  // The box around the known cells, one unknown cell of margin around, is the window exported.
  std::vector<Cell> row(static_cast<size_t>(width_));
  int c_lo = width_, c_hi = -1, r_lo = height_, r_hi = -1;
  for (int r = 0; r < height_; ++r) {
    ReadRow(layer, first_layers, r, 0, width_, row.data());
    for (int c = 0; c < width_; ++c) {
      if (row[static_cast<size_t>(c)].confidence >= unknown_below) {
        c_lo = std::min(c_lo, c);
        c_hi = std::max(c_hi, c);
        r_lo = std::min(r_lo, r);
        r_hi = std::max(r_hi, r);
      }
    }
  }
  CellWindow known{min_ix_, min_iy_, 0, 0};  // no known cell: an empty export
  if (c_hi >= 0) {
    c_lo = std::max(0, c_lo - 1);
    r_lo = std::max(0, r_lo - 1);
    c_hi = std::min(width_ - 1, c_hi + 1);
    r_hi = std::min(height_ - 1, r_hi + 1);
    known = {min_ix_ + c_lo, min_iy_ + r_lo, static_cast<uint32_t>(c_hi - c_lo + 1),
             static_cast<uint32_t>(r_hi - r_lo + 1)};
  }
  return ExportCellsIn(known, layer, first_layers, unknown_below);
}

CellWindow WindowOverBox(double resolution_m, double min_x, double min_y, double max_x,
                         double max_y, int64_t max_cells_per_side) {
  if (!(resolution_m > 0) || !std::isfinite(resolution_m)) {
    throw std::invalid_argument("window: the resolution must be a positive number");
  }
  for (const double v : {min_x, min_y, max_x, max_y}) {
    if (!std::isfinite(v)) throw std::invalid_argument("window: the box must be finite");
  }
  if (!(min_x < max_x) || !(min_y < max_y)) {
    throw std::invalid_argument("window: the box needs min < max along x and along y");
  }
  // In cells first, as doubles: a box of 1e300 m must be refused, not overflow an int64.
  const double lo_x = std::floor(min_x / resolution_m), lo_y = std::floor(min_y / resolution_m);
  const double hi_x = std::ceil(max_x / resolution_m), hi_y = std::ceil(max_y / resolution_m);
  const double limit = static_cast<double>(max_cells_per_side);
  if (hi_x - lo_x > limit || hi_y - lo_y > limit || std::abs(lo_x) > 1e15 ||
      std::abs(lo_y) > 1e15) {
    throw std::invalid_argument("window: the box spans more than " +
                                std::to_string(max_cells_per_side) + " cells along an axis");
  }
  CellWindow w;
  w.ix0 = static_cast<int64_t>(lo_x);
  w.iy0 = static_cast<int64_t>(lo_y);
  // A box that ends exactly on a cell edge does not take the cell beyond it; one cell at least.
  w.width = static_cast<uint32_t>(std::max(1.0, hi_x - lo_x));
  w.height = static_cast<uint32_t>(std::max(1.0, hi_y - lo_y));
  return w;
}

GridExport LayeredGrid::ExportCellsIn(const CellWindow& window, std::optional<int> layer,
                                      int first_layers, double unknown_below) const {
  GridExport e;
  e.resolution_m = params_.resolution_m;
  e.origin_x = static_cast<double>(window.ix0) * params_.resolution_m;
  e.origin_y = static_cast<double>(window.iy0) * params_.resolution_m;
  e.width = window.width;
  e.height = window.height;
  e.layer_count = static_cast<uint32_t>(layer_count());
  e.layer_bounds_m = params_.layer_bounds_m;
  e.occupancy.assign(window.cells(), GridExport::kUnknown);
  e.confidence.assign(window.cells(), 0);
  if (width_ == 0) return e;
  // Only the part of the window that overlaps the grid is read; the rest stays unknown.
  const int64_t ix_lo = std::max(window.ix0, min_ix_);
  const int64_t iy_lo = std::max(window.iy0, min_iy_);
  const int64_t ix_hi = std::min(window.ix0 + static_cast<int64_t>(window.width), min_ix_ + width_);
  const int64_t iy_hi =
      std::min(window.iy0 + static_cast<int64_t>(window.height), min_iy_ + height_);
  if (ix_lo >= ix_hi) return e;
  const int c0 = static_cast<int>(ix_lo - min_ix_), c1 = static_cast<int>(ix_hi - min_ix_);
  std::vector<Cell> row(static_cast<size_t>(c1 - c0));
  for (int64_t iy = iy_lo; iy < iy_hi; ++iy) {
    ReadRow(layer, first_layers, static_cast<int>(iy - min_iy_), c0, c1, row.data());
    const size_t start = static_cast<size_t>(iy - window.iy0) * window.width +
                         static_cast<size_t>(ix_lo - window.ix0);
    for (int c = c0; c < c1; ++c) {
      const size_t i = start + static_cast<size_t>(c - c0);
      PutCell(row[static_cast<size_t>(c - c0)], unknown_below, &e.occupancy[i], &e.confidence[i]);
    }
  }
  return e;
}

GridExport LayeredGrid::ExportWindow(const CellWindow& window, std::optional<int> layer,
                                     double unknown_below) const {
  if (!layer) return ExportBelowWindow(window, layer_count(), unknown_below);
  CheckLayer(*layer);
  GridExport e = ExportCellsIn(window, layer, 0, unknown_below);
  e.combined = false;
  e.layer = static_cast<uint32_t>(*layer);
  return e;
}

GridExport LayeredGrid::ExportBelowWindow(const CellWindow& window, int first_layers,
                                          double unknown_below) const {
  CheckFirstLayers(first_layers);
  GridExport e = ExportCellsIn(window, std::nullopt, first_layers, unknown_below);
  e.combined = true;
  e.combined_layers = static_cast<uint32_t>(first_layers);
  return e;
}

GridExport LayeredGrid::Export(std::optional<int> layer, double unknown_below) const {
  if (!layer) return ExportBelow(layer_count(), unknown_below);
  CheckLayer(*layer);
  GridExport e = ExportCells(layer, 0, unknown_below);
  e.combined = false;
  e.layer = static_cast<uint32_t>(*layer);
  return e;
}

GridExport LayeredGrid::ExportBelow(int first_layers, double unknown_below) const {
  CheckFirstLayers(first_layers);
  GridExport e = ExportCells(std::nullopt, first_layers, unknown_below);
  e.combined = true;
  e.combined_layers = static_cast<uint32_t>(first_layers);
  return e;
}

void LayeredGrid::MergeWeighted(const LayeredGrid& local, int shift_x, int shift_y) {
  if (local.layer_count() != layer_count() || std::abs(local.resolution() - resolution()) > 1e-12) {
    throw std::invalid_argument(
        "occupancy grid: cannot merge grids of different layers or "
        "resolution");
  }
  if (local.empty()) return;
  EnsureCovers(local.min_ix_ + shift_x, local.min_iy_ + shift_y,
               local.min_ix_ + shift_x + local.width_ - 1,
               local.min_iy_ + shift_y + local.height_ - 1);
  const int dc = static_cast<int>(local.min_ix_ + shift_x - min_ix_);
  const int dr = static_cast<int>(local.min_iy_ + shift_y - min_iy_);
  std::vector<Layer>& layers = MutableLayers();
  for (size_t l = 0; l < layers.size(); ++l) {
    const Layer& S = (*local.layers_)[l];
    Layer& G = layers[l];
    for (int r = 0; r < local.height_; ++r) {
      const float* se = S.empty.ptr<float>(r);
      const float* so = S.occupied.ptr<float>(r);
      const float* sk = S.confidence.ptr<float>(r);
      float* ge = G.empty.ptr<float>(r + dr) + dc;
      float* go = G.occupied.ptr<float>(r + dr) + dc;
      float* gk = G.confidence.ptr<float>(r + dr) + dc;
      for (int c = 0; c < local.width_; ++c) {
        const float wl = sk[c];
        if (wl <= 0) continue;
        const float wg = gk[c];
        const float sum = wl + wg;
        ge[c] = (wg * ge[c] + wl * se[c]) / sum;
        go[c] = (wg * go[c] + wl * so[c]) / sum;
        gk[c] = wg + wl - wg * wl;
      }
    }
  }
}

Registration CorrelateMaps(const LayeredGrid& local, const LayeredGrid& global,
                           double search_radius_m) {
  if (std::abs(local.resolution() - global.resolution()) > 1e-12) {
    throw std::invalid_argument("CorrelateMaps: the two grids have different resolutions");
  }
  if (!(search_radius_m >= 0)) {
    throw std::invalid_argument("CorrelateMaps: search_radius_m must be >= 0");
  }
  Registration reg;
  if (local.empty() || global.empty()) return reg;
  const cv::Mat ml = local.SyntheticMap();
  const cv::Mat mg = global.SyntheticMap();
  struct Sample {
    int64_t ix, iy;
    float v;
  };
  std::vector<Sample> samples;
  for (int r = 0; r < ml.rows; ++r) {
    const float* row = ml.ptr<float>(r);
    for (int c = 0; c < ml.cols; ++c) {
      if (row[c] > 1e-3F) samples.push_back({local.min_ix() + c, local.min_iy() + r, row[c]});
    }
  }
  reg.local_cells = samples.size();
  const int S = static_cast<int>(std::ceil(search_radius_m / local.resolution()));
  const int side = 2 * S + 1;
  std::vector<double> scores(static_cast<size_t>(side * side), 0.0);
  for (int sy = -S; sy <= S; ++sy) {
    for (int sx = -S; sx <= S; ++sx) {
      double score = 0;
      for (const auto& s : samples) {
        const int64_t c = s.ix + sx - global.min_ix();
        const int64_t r = s.iy + sy - global.min_iy();
        if (c < 0 || r < 0 || c >= mg.cols || r >= mg.rows) continue;
        score += static_cast<double>(s.v) *
                 static_cast<double>(mg.at<float>(static_cast<int>(r), static_cast<int>(c)));
      }
      scores[static_cast<size_t>((sy + S) * side + (sx + S))] = score;
    }
  }
  const auto at = [&](int sx, int sy) {
    return scores[static_cast<size_t>((sy + S) * side + (sx + S))];
  };
  reg.zero_score = at(0, 0);
  reg.score = reg.zero_score;
  // Ties keep the smaller shift: scan outward from zero.
  for (int sy = -S; sy <= S; ++sy) {
    for (int sx = -S; sx <= S; ++sx) {
      const double v = at(sx, sy);
      const bool smaller =
          std::abs(sx) + std::abs(sy) < std::abs(reg.dx_cells) + std::abs(reg.dy_cells);
      if (v > reg.score || (v == reg.score && smaller)) {
        reg.score = v;
        reg.dx_cells = sx;
        reg.dy_cells = sy;
      }
    }
  }
  const auto refine = [](double lo, double mid, double hi) {
    const double denom = lo - 2 * mid + hi;
    return denom < 0 ? std::clamp(0.5 * (lo - hi) / denom, -0.5, 0.5) : 0.0;
  };
  double fx = 0, fy = 0;
  const auto sharp = [&](double lo, double hi) {
    return reg.score > 0 ? (2 * reg.score - lo - hi) / reg.score : 0.0;
  };
  if (std::abs(reg.dx_cells) < S) {
    const double lo = at(reg.dx_cells - 1, reg.dy_cells), hi = at(reg.dx_cells + 1, reg.dy_cells);
    fx = refine(lo, reg.score, hi);
    reg.sharpness_x = sharp(lo, hi);
  }
  if (std::abs(reg.dy_cells) < S) {
    const double lo = at(reg.dx_cells, reg.dy_cells - 1), hi = at(reg.dx_cells, reg.dy_cells + 1);
    fy = refine(lo, reg.score, hi);
    reg.sharpness_y = sharp(lo, hi);
  }
  reg.dx_m = (reg.dx_cells + fx) * local.resolution();
  reg.dy_m = (reg.dy_cells + fy) * local.resolution();
  return reg;
}

}  // namespace epmap::occupancy
