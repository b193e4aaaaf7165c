#include "clients/sim/renderer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace epmap::sim {

namespace {

constexpr double kNearZ = 0.01;  // metres: faces are clipped in front of this plane

// A face in the camera frame, ready for scanning: 1/z = A x + B y + C, and texel coordinates
// s = Ns(x, y) / (1/z), t = Nt(x, y) / (1/z) with Ns, Nt affine (a homography).
struct PreparedQuad {
  double A, B, C;
  double sa, sb, sc;  // Ns = sa x + sb y + sc
  double ta, tb, tc;  // Nt = ta x + tb y + tc
  const Texture* texture;
  float shade;
  uint8_t object;
};

struct Vertex {
  double x, y;  // pixel coordinates
};

// Prepares a quad for this view; returns false when it cannot be seen (behind, edge-on, back
// face of a one-sided quad).
bool Prepare(const Quad& q, const Scene& scene, const PinholeCamera& cam,
             const Eigen::Isometry3d& T_cam_world, PreparedQuad* p,
             std::array<Eigen::Vector3d, 4>* corners) {
  const Eigen::Matrix3d& R = T_cam_world.linear();
  const Eigen::Vector3d o = T_cam_world * q.origin;
  const Eigen::Vector3d u = R * q.edge_u;
  const Eigen::Vector3d v = R * q.edge_v;
  const Eigen::Vector3d n = v.cross(u);  // front normal, not normalised
  const double c = n.dot(o);             // plane: n . X = c
  const double scale = n.norm() * (o.norm() + u.norm() + v.norm());
  if (std::abs(c) <= 1e-12 * scale) return false;  // edge-on
  if (c > 0 && !q.two_sided) return false;         // camera behind the front side
  (*corners)[0] = o;
  (*corners)[1] = o + u;
  (*corners)[2] = o + u + v;
  (*corners)[3] = o + v;
  bool any_in_front = false;
  for (const auto& k : *corners) any_in_front |= k.z() > kNearZ;
  if (!any_in_front) return false;

  // A point on the ray of pixel (x, y) is z * d with d = ((x - cx)/fx, (y - cy)/fy, 1); for a
  // vector w, w . d = (wx/fx) x + (wy/fy) y + (wz - wx cx/fx - wy cy/fy): affine in (x, y).
  const auto affine = [&](const Eigen::Vector3d& w, double* a, double* b, double* k) {
    *a = w.x() / cam.fx;
    *b = w.y() / cam.fy;
    *k = w.z() - w.x() * cam.cx / cam.fx - w.y() * cam.cy / cam.fy;
  };
  // 1/z = (n . d) / c.
  affine(n / c, &p->A, &p->B, &p->C);
  // Face coordinates a = D_u . (X - o), b = D_v . (X - o), with D_u, D_v the dual basis of
  // (u, v, n). With X = z d: a = z (D_u . d - (D_u . o) / z)  ->  numerator affine in (x, y).
  Eigen::Matrix3d basis;
  basis << u, v, n;
  const Eigen::Matrix3d dual = basis.inverse();  // rows: D_u, D_v, D_n
  double ua, ub, uk, va, vb, vk;
  affine(dual.row(0).transpose(), &ua, &ub, &uk);
  affine(dual.row(1).transpose(), &va, &vb, &vk);
  const double du_o = dual.row(0).dot(o), dv_o = dual.row(1).dot(o);
  // s = s0 + span_s * a  =>  Ns = s0 * (1/z) + span_s * (D_u . d - (D_u . o)(1/z)).
  const double s0 = q.tex_origin.x(), t0 = q.tex_origin.y();
  const double ss = q.tex_span.x(), ts = q.tex_span.y();
  p->sa = s0 * p->A + ss * (ua - du_o * p->A);
  p->sb = s0 * p->B + ss * (ub - du_o * p->B);
  p->sc = s0 * p->C + ss * (uk - du_o * p->C);
  p->ta = t0 * p->A + ts * (va - dv_o * p->A);
  p->tb = t0 * p->B + ts * (vb - dv_o * p->B);
  p->tc = t0 * p->C + ts * (vk - dv_o * p->C);
  p->texture = &scene.textures.at(static_cast<size_t>(q.texture));
  p->shade = q.shade;
  p->object = static_cast<uint8_t>(std::clamp(q.object, 0, 255));
  return true;
}

// Clips the polygon to z >= kNearZ (Sutherland-Hodgman, one plane) and projects it.
int ClipAndProject(const std::array<Eigen::Vector3d, 4>& corners, const PinholeCamera& cam,
                   std::array<Vertex, 8>* out) {
  int count = 0;
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector3d& a = corners[static_cast<size_t>(i)];
    const Eigen::Vector3d& b = corners[static_cast<size_t>((i + 1) % 4)];
    const bool a_in = a.z() >= kNearZ, b_in = b.z() >= kNearZ;
    const auto emit = [&](const Eigen::Vector3d& p) {
      (*out)[static_cast<size_t>(count++)] = {cam.fx * p.x() / p.z() + cam.cx,
                                              cam.fy * p.y() / p.z() + cam.cy};
    };
    if (a_in) emit(a);
    if (a_in != b_in) {
      const double t = (kNearZ - a.z()) / (b.z() - a.z());
      emit(a + t * (b - a));
    }
  }
  return count;
}

// Pass 1: writes the face's inverse depth where it is nearer than what the buffer holds.
void Rasterise(const PreparedQuad& p, int index, const std::array<Vertex, 8>& poly, int n,
               int width, int height, float* inv_depth, int32_t* face) {
  double ymin = poly[0].y, ymax = poly[0].y, xmin = poly[0].x, xmax = poly[0].x;
  for (int i = 1; i < n; ++i) {
    ymin = std::min(ymin, poly[static_cast<size_t>(i)].y);
    ymax = std::max(ymax, poly[static_cast<size_t>(i)].y);
    xmin = std::min(xmin, poly[static_cast<size_t>(i)].x);
    xmax = std::max(xmax, poly[static_cast<size_t>(i)].x);
  }
  if (xmax < 0 || xmin > width - 1 || ymax < 0 || ymin > height - 1) return;
  const int y0 = std::max(0, static_cast<int>(std::ceil(ymin)));
  const int y1 = std::min(height - 1, static_cast<int>(std::floor(ymax)));
  for (int y = y0; y <= y1; ++y) {
    // Pixel centres inside the convex outline: intersect the row with each edge (half-open in
    // y so that a vertex on the row counts once).
    double xl = std::numeric_limits<double>::infinity(), xr = -xl;
    for (int i = 0; i < n; ++i) {
      const Vertex& a = poly[static_cast<size_t>(i)];
      const Vertex& b = poly[static_cast<size_t>((i + 1) % n)];
      if ((a.y <= y && y < b.y) || (b.y <= y && y < a.y)) {
        const double x = a.x + (y - a.y) * (b.x - a.x) / (b.y - a.y);
        xl = std::min(xl, x);
        xr = std::max(xr, x);
      }
    }
    if (!(xl <= xr)) continue;
    const int x0 = std::max(0, static_cast<int>(std::ceil(xl)));
    const int x1 = std::min(width - 1, static_cast<int>(std::ceil(xr)) - 1);
    if (x0 > x1) continue;
    float* zrow = inv_depth + static_cast<size_t>(y) * width;
    int32_t* frow = face + static_cast<size_t>(y) * width;
    const double row_base = p.B * y + p.C;
    for (int x = x0; x <= x1; ++x) {
      const float iz = static_cast<float>(p.A * x + row_base);
      if (iz > zrow[x]) {
        zrow[x] = iz;
        frow[x] = index;
      }
    }
  }
}

// Pass 2 for one row: each run of pixels that see the same face is shaded in two steps, the
// homography (texel coordinates and footprint, a loop the compiler vectorises) and then the
// texture lookups.
template <int C>
void ShadeRow(const std::vector<PreparedQuad>& prepared, const int32_t* face, int y, int width,
              float background, float* radiance, uint8_t* object, double* S, double* T, double* F) {
  int x = 0;
  while (x < width) {
    const int id = face[x];
    int end = x + 1;
    while (end < width && face[end] == id) ++end;
    if (id < 0) {
      for (int i = x * C; i < end * C; ++i) radiance[i] = background;
      std::fill(object + x, object + end, uint8_t{0});
      x = end;
      continue;
    }
    const PreparedQuad& p = prepared[static_cast<size_t>(id)];
    const double iz0 = p.B * y + p.C, s0 = p.sb * y + p.sc, t0 = p.tb * y + p.tc;
    for (int i = x; i < end; ++i) {
      const double xd = i;
      const double z = 1.0 / (p.A * xd + iz0);
      const double s = (p.sa * xd + s0) * z;
      const double t = (p.ta * xd + t0) * z;
      // Texels per pixel along x and y from the homography's derivatives.
      const double dsdx = (p.sa - s * p.A) * z, dtdx = (p.ta - t * p.A) * z;
      const double dsdy = (p.sb - s * p.B) * z, dtdy = (p.tb - t * p.B) * z;
      const double fx = dsdx * dsdx + dtdx * dtdx, fy = dsdy * dsdy + dtdy * dtdy;
      S[i] = s;
      T[i] = t;
      F[i] = fx > fy ? fx : fy;
    }
    const float shade = p.shade;
    for (int i = x; i < end; ++i) {
      float texel[4] = {0, 0, 0, 0};
      p.texture->Sample(S[i], T[i], F[i], texel);
      float* px = radiance + static_cast<size_t>(i) * C;
      for (int k = 0; k < C; ++k) px[k] = texel[k] * shade;
    }
    std::fill(object + x, object + end, p.object);
    x = end;
  }
}

template <int C>
void Shade(const std::vector<PreparedQuad>& prepared, const cv::Mat& face_buffer, float background,
           RenderOutput* out) {
  // Per-row scratch: texel coordinates and squared footprint of each pixel.
  std::vector<double> scratch(3 * static_cast<size_t>(face_buffer.cols));
  double* S = scratch.data();
  double* T = S + face_buffer.cols;
  double* F = T + face_buffer.cols;
  for (int y = 0; y < face_buffer.rows; ++y) {
    ShadeRow<C>(prepared, face_buffer.ptr<int32_t>(y), y, face_buffer.cols, background,
                out->radiance.ptr<float>(y), out->object.ptr<uint8_t>(y), S, T, F);
  }
}

}  // namespace

void Render(const Scene& scene, const std::vector<Quad>& moving, const PinholeCamera& camera,
            const Eigen::Isometry3d& T_world_cam, RenderOutput* out, float background) {
  if (camera.width <= 0 || camera.height <= 0 || camera.fx <= 0 || camera.fy <= 0) {
    throw std::invalid_argument("Render: the camera needs a positive size and focal length");
  }
  if (scene.channels != 1 && scene.channels != 3) {
    throw std::invalid_argument("Render: a scene has 1 or 3 channels");
  }
  const int W = camera.width, H = camera.height;
  out->radiance.create(H, W, CV_32FC(scene.channels));
  out->inv_depth.create(H, W, CV_32FC1);
  out->object.create(H, W, CV_8UC1);
  std::fill_n(out->inv_depth.ptr<float>(), static_cast<size_t>(W) * H, 0.0F);
  out->face.create(H, W, CV_32SC1);
  cv::Mat& face_buffer = out->face;
  std::fill_n(face_buffer.ptr<int32_t>(), static_cast<size_t>(W) * H, -1);

  const Eigen::Isometry3d T_cam_world = T_world_cam.inverse();
  std::vector<PreparedQuad> prepared;
  prepared.reserve(scene.quads.size() + moving.size());
  std::array<Eigen::Vector3d, 4> corners;
  std::array<Vertex, 8> poly;
  auto* zbuf = out->inv_depth.ptr<float>();
  auto* fbuf = face_buffer.ptr<int32_t>();
  for (const std::vector<Quad>* list : {&scene.quads, &moving}) {
    for (const Quad& q : *list) {
      PreparedQuad p;
      if (!Prepare(q, scene, camera, T_cam_world, &p, &corners)) continue;
      if (p.texture->channels() != scene.channels) {
        throw std::invalid_argument("Render: a texture's channel count differs from the scene's");
      }
      const int n = ClipAndProject(corners, camera, &poly);
      if (n < 3) continue;
      prepared.push_back(p);
      Rasterise(p, static_cast<int>(prepared.size()) - 1, poly, n, W, H, zbuf, fbuf);
    }
  }

  // Pass 2: shade each pixel once with its visible face.
  if (scene.channels == 3) {
    Shade<3>(prepared, face_buffer, background, out);
  } else {
    Shade<1>(prepared, face_buffer, background, out);
  }
}

}  // namespace epmap::sim
