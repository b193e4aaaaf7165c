#pragma once
// Portable Float Map (PFM) reading and writing: the format of gt_disparity0/ and of every
// float disparity the tools exchange. Single channel ("Pf") float32, non-finite = unknown.

#include <filesystem>
#include <opencv2/core.hpp>

namespace epmap::imaging {

// Writes a CV_32FC1 image as little-endian PFM (scale -1), rows stored bottom-up as the
// format requires. Throws std::runtime_error if the file cannot be written.
void WritePfm(const std::filesystem::path& path, const cv::Mat& image);

// Reads a single-channel PFM into CV_32FC1 (top row first). Throws std::runtime_error
// with the reason on a missing or malformed file.
cv::Mat ReadPfm(const std::filesystem::path& path);

}  // namespace epmap::imaging
