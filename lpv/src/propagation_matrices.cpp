// The propagation's matrices (propagation_matrices.h).
#include "propagation_matrices.h"

#include <cmath>

#include "drtv/formats/error.h"
#include "drtv/formats/sh.h"

namespace drtv::lpv::detail {
namespace {

// sh.h's coefficient of each axis: x -> 3 (Y11), y -> 1 (Y1-1), z -> 2 (Y10).
constexpr int kAxisCoeff[3] = {3, 1, 2};

std::array<DirMatrix, kDirs> buildMatrices() {
  std::array<DirMatrix, kDirs> out{};
  for (int d = 0; d < kDirs; ++d) {
    const glm::vec3 t = glm::vec3(dirVector(d));
    const int axis = d / 2;
    // The far face: towards t, re-emitted about t. The 4 side faces: centres at t +- 0.5 e_side.
    glm::dmat4 M(0.0);  // M[col][row]: dst[row] += M[col][row] * src[col]
    auto addFace = [&](const glm::vec3& towards, const glm::vec3& face_normal, double solid_angle) {
      const sh::Sh4 lobe = sh::cosineLobe(face_normal);
      const sh::Sh4 eval = sh::evaluate(glm::normalize(towards));
      for (int col = 0; col < 4; ++col)
        for (int row = 0; row < 4; ++row) M[col][row] += solid_angle / sh::kPi * double(lobe[row]) * double(eval[col]);
    };
    addFace(t, t, kFarFaceSolidAngle);
    for (int side = 0; side < 3; ++side) {
      if (side == axis) continue;
      for (int s = -1; s <= 1; s += 2) {
        glm::vec3 e(0.f);
        e[side] = float(s);
        addFace(t + 0.5f * e, e, kSideFaceSolidAngle);
      }
    }
    DirMatrix m;
    m.a = kAxisCoeff[axis];
    m.o1 = kAxisCoeff[(axis + 1) % 3];
    m.o2 = kAxisCoeff[(axis + 2) % 3];
    m.m00 = float(M[0][0]), m.m0a = float(M[m.a][0]), m.ma0 = float(M[0][m.a]), m.maa = float(M[m.a][m.a]);
    m.moo = float(M[m.o1][m.o1]);
    DRTV_CHECK(std::abs(M[m.o1][m.o1] - M[m.o2][m.o2]) < 1e-6);
    for (int col = 0; col < 4; ++col)
      for (int row = 0; row < 4; ++row) {
        const bool kept = (row == 0 && (col == 0 || col == m.a)) || (row == m.a && (col == 0 || col == m.a)) ||
                          (row == col && (row == m.o1 || row == m.o2));
        if (!kept) DRTV_CHECK(std::abs(M[col][row]) < 1e-6);
      }
    out[size_t(d)] = m;
  }
  return out;
}

}  // namespace

const std::array<DirMatrix, kDirs>& matrices() {
  static const std::array<DirMatrix, kDirs> m = buildMatrices();
  return m;
}

}  // namespace drtv::lpv::detail
