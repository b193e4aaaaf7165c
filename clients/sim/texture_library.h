#pragma once
// Procedural, deterministic, band-limited textures of an indoor world: painted walls with some
// texture, plain surfaces, wood, fabric, floor tiles, posters and book spines. Every generator
// returns CV_8UC3 (BGR) with power-of-two sides; the noise-based ones are periodic so that they
// tile a large surface without seams. Spectra stop below 0.5 cycles/texel and printed patterns
// are drawn anti-aliased at twice the size, averaged down and softened, so level 0 of the mip
// pyramid already has no content the texel grid cannot carry.

#include <opencv2/core.hpp>

#include "clients/sim/random.h"

namespace epmap::sim::textures {

struct Spectrum {
  double beta = 1.0;        // amplitude ~ 1/f^beta (natural surfaces: about 1)
  double min_cycles = 1.0;  // lowest frequency kept, cycles per texture side
  double cutoff = 0.3;      // highest frequency, cycles per texel (raised-cosine roll-off)
  double stretch = 1.0;     // > 1: structures elongated along the texture's x (wood grain)
};

// Zero-mean, unit-variance periodic noise (CV_32FC1) with the given amplitude spectrum, made by
// an inverse DFT of a random spectrum (so periodic and band-limited by construction).
cv::Mat BandLimitedNoise(int width, int height, const Spectrum& spectrum, Rng& rng);

// A painted wall: `colour` (BGR 0..255) with 1/f texture of `contrast` grey levels (std dev)
// and a faint colour variation. contrast ~1 gives a plain surface.
cv::Mat Paint(Rng& rng, int size, const cv::Scalar& colour, double contrast);
// Wood: fine grain and annual-ring stripes between a light and a dark tone, running along the
// texture's x (or its y when grain_along_y).
cv::Mat Wood(Rng& rng, int size, const cv::Scalar& light, const cv::Scalar& dark,
             bool grain_along_y = false);
// Fabric / carpet: fine isotropic texture of strong contrast.
cv::Mat Fabric(Rng& rng, int size, const cv::Scalar& colour, double contrast);
// Floor tiles: tiles_per_side square tiles with grout lines and per-tile tone variation.
cv::Mat Tiles(Rng& rng, int size, int tiles_per_side, const cv::Scalar& colour,
              const cv::Scalar& grout);
// A printed poster (shapes, stripes, title and lines of text) with a white margin.
cv::Mat Poster(Rng& rng, int width, int height);
// A row of book spines (x along the shelf), with title bands and dark gaps between books.
cv::Mat Books(Rng& rng, int width, int height);
// A toy's printed surface: saturated blobs and a checker, easy to tell apart from the room.
cv::Mat Toy(Rng& rng, int size);

}  // namespace epmap::sim::textures
