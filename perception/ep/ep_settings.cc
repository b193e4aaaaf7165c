#include "perception/ep/ep_settings.h"

#include <functional>
#include <map>
#include <sstream>
#include <stdexcept>
#include <variant>

namespace epmap::ep {

namespace {

using Field = std::variant<double*, int*, bool*>;

std::vector<std::pair<std::string, Field>> Fields(EpParams* p) {
  return {
      {"prediction.image_step", &p->prediction.image_step},
      {"prediction.splat_radius_px", &p->prediction.splat_radius_px},
      {"prediction.crack_max_step_px", &p->prediction.crack_max_step_px},
      {"prediction.min_depth_m", &p->prediction.min_depth_m},
      {"prediction.max_hole_fill_px", &p->prediction.max_hole_fill_px},
      {"comparator.lambda", &p->comparator.lambda},
      {"comparator.alpha", &p->comparator.alpha},
      {"comparator.threshold_grey", &p->comparator.threshold_grey},
      {"comparator.compensate_exposure", &p->comparator.compensate_exposure},
      {"comparator.open_radius_px", &p->comparator.open_radius_px},
      {"comparator.min_region_area_px", &p->comparator.min_region_area_px},
      {"comparator.unexpected_weight", &p->comparator.unexpected_weight},
      {"comparator.close_radius_px", &p->comparator.close_radius_px},
      {"comparator.grow_threshold_grey", &p->comparator.grow_threshold_grey},
      {"stereo_check.enabled", &p->stereo_check.enabled},
      {"stereo_check.threshold_grey", &p->stereo_check.threshold_grey},
      {"stereo_check.window_px", &p->stereo_check.window_px},
      {"stereo_check.open_radius_px", &p->stereo_check.open_radius_px},
      {"stereo_check.min_region_area_px", &p->stereo_check.min_region_area_px},
      {"sgbm.min_disparity", &p->sgbm.min_disparity},
      {"sgbm.num_disparities", &p->sgbm.num_disparities},
      {"sgbm.block_size", &p->sgbm.block_size},
      {"sgbm.p1", &p->sgbm.p1},
      {"sgbm.p2", &p->sgbm.p2},
      {"sgbm.uniqueness_ratio", &p->sgbm.uniqueness_ratio},
      {"sgbm.speckle_window", &p->sgbm.speckle_window},
      {"sgbm.speckle_range", &p->sgbm.speckle_range},
      {"sgbm.disp12_max_diff", &p->sgbm.disp12_max_diff},
      {"sgbm.pre_filter_cap", &p->sgbm.pre_filter_cap},
      {"sgbm.mode", &p->sgbm.mode},
      {"roi.context_px", &p->roi.context_px},
      {"roi.band_rows", &p->roi.band_rows},
      {"roi.split_width_px", &p->roi.split_width_px},
      {"roi.merge_slack", &p->roi.merge_slack},
      {"refresh.every_n_frames", &p->refresh.every_n_frames},
      {"refresh.max_recompute_share", &p->refresh.max_recompute_share},
      {"refresh.rolling_period_frames", &p->refresh.rolling_period_frames},
      {"refresh.rolling_every_frames", &p->refresh.rolling_every_frames},
      {"max_rotation_rate_rad_s", &p->max_rotation_rate_rad_s},
      {"max_translation_speed_m_s", &p->max_translation_speed_m_s},
      {"min_frame_interval_s", &p->min_frame_interval_s},
      {"max_frame_interval_s", &p->max_frame_interval_s},
      {"earlier_views", &p->earlier_views},
      {"earlier_view_max_age_s", &p->earlier_view_max_age_s},
      {"recompute_margin_px", &p->recompute_margin_px},
      {"border_batch_px", &p->border_batch_px},
      {"uncovered_margin_px", &p->uncovered_margin_px},
      {"history_reset_px", &p->history_reset_px},
      {"remeasure_dynamic", &p->remeasure_dynamic},
      {"retry_unmatched_frames", &p->retry_unmatched_frames},
      {"retry_every_frames", &p->retry_every_frames},
      {"narrow_search", &p->narrow_search},
      {"roi.range_margin_px", &p->roi.range_margin_px},
      {"roi.range_margin_share", &p->roi.range_margin_share},
      {"roi.range_unknown_share", &p->roi.range_unknown_share},
  };
}

}  // namespace

void SetEpParam(EpParams* params, const std::string& key, const std::string& value) {
  for (auto& [name, field] : Fields(params)) {
    if (name != key) continue;
    std::istringstream in(value);
    bool ok = false;
    if (auto* d = std::get_if<double*>(&field)) {
      ok = static_cast<bool>(in >> **d);
    } else if (auto* i = std::get_if<int*>(&field)) {
      ok = static_cast<bool>(in >> **i);
    } else if (auto* b = std::get_if<bool*>(&field)) {
      if (value == "true" || value == "1") {
        **b = true;
        ok = true;
      } else if (value == "false" || value == "0") {
        **b = false;
        ok = true;
      }
      in.setstate(std::ios::eofbit);
    }
    std::string rest;
    if (!ok || (in >> rest)) {
      throw std::invalid_argument("EP parameter '" + key + "': cannot use value '" + value + "'");
    }
    return;
  }
  std::string known;
  for (const auto& [name, field] : Fields(params)) known += (known.empty() ? "" : ", ") + name;
  throw std::invalid_argument("unknown EP parameter '" + key + "' (known: " + known + ")");
}

std::vector<std::pair<std::string, std::string>> ListEpParams(const EpParams& params) {
  EpParams copy = params;
  std::vector<std::pair<std::string, std::string>> out;
  for (const auto& [name, field] : Fields(&copy)) {
    std::ostringstream s;
    std::visit([&](auto* v) { s << std::boolalpha << *v; }, field);
    out.emplace_back(name, s.str());
  }
  return out;
}

}  // namespace epmap::ep
