#pragma once
// The occupancy grid in the layout of ROS map_server (nav2_map_server / map_server): a PGM
// image (top row = highest y, white = free, black = occupied) and a YAML file with image,
// resolution, origin [x, y, yaw], negate, occupied_thresh, free_thresh. Functions return the
// bytes; writing them is the caller's business.

#include <opencv2/core.hpp>
#include <string>

#include "perception/occupancy/layered_grid.h"

namespace epmap::occupancy {

struct MapServerThresholds {
  double occupied = 0.65;  // map_server's usual values (map_saver writes these)
  double free = 0.196;
};

// Binary PGM (P5). Known cells: 255 (1 - occupancy/100), so map_server reads back
// p = occupancy/100 with negate = 0; unknown cells: 205, between the two thresholds.
std::string EncodePgm(const GridExport& grid);

// The YAML that goes beside the PGM (image is the PGM's file name relative to the YAML).
std::string MapServerYaml(const GridExport& grid, const std::string& image,
                          const MapServerThresholds& thresholds = {});

// A picture for people (BGR, y up, `scale` pixels per cell): unknown grey, free white,
// occupied dark, with the confidence shown as saturation of the blue tint.
cv::Mat RenderGrid(const GridExport& grid, int scale = 4);

}  // namespace epmap::occupancy
