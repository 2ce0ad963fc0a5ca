// The table exports: MERL .binary and the ASTM E1392-style table.
#include <cmath>
#include <cstdint>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "common/error.h"
#include "common/io.h"
#include "common/math.h"
#include "estimation/fit/brdf_table.h"
#include "export/export.h"
#include "reflectance/registry.h"

namespace gonio {

size_t WriteMerlBinary(const FittedMaterial& material, const std::filesystem::path& out) {
  // The directions of every cell with both directions above the horizon.
  std::vector<size_t> index;
  std::vector<double> ti, tr, ph;
  for (int th = 0; th < merl::kThetaH; ++th) {
    for (int td = 0; td < merl::kThetaD; ++td) {
      for (int pd = 0; pd < merl::kPhiD; ++pd) {
        Angles<double> a;
        if (!merl::CellAngles(th, td, pd, &a)) continue;
        index.push_back(merl::Index(th, td, pd));
        ti.push_back(a.theta_i), tr.push_back(a.theta_r), ph.push_back(a.phi);
      }
    }
  }
  // Cells without data carry -1 (negative), as in the MERL database.
  std::vector<double> raw(3 * merl::kCells, -1.0);
  std::vector<double> f(index.size());
  for (int c = 0; c < 3; ++c) {
    EvaluateBatch(material.model, material.channel_params[c], ti.data(), tr.data(), ph.data(),
                  index.size(), f.data(), 0);
    for (size_t k = 0; k < index.size(); ++k) {
      if (!std::isfinite(f[k]) || f[k] < 0) {
        throw NumericalError(
            fmt::format("merl: {} gives {} at theta_i {:.2f}, theta_r {:.2f}, phi {:.2f} deg",
                        material.model, f[k], RadToDeg(ti[k]), RadToDeg(tr[k]), RadToDeg(ph[k])));
      }
      raw[c * merl::kCells + index[k]] = f[k] / merl::kScale[c];
    }
  }
  WriteAtomically(out, [&](const std::filesystem::path& tmp) {
    std::ofstream os(tmp, std::ios::binary);
    const int32_t dims[3] = {merl::kThetaH, merl::kThetaD, merl::kPhiD};
    os.write(reinterpret_cast<const char*>(dims), sizeof(dims));
    os.write(reinterpret_cast<const char*>(raw.data()), raw.size() * sizeof(double));
    return static_cast<bool>(os);
  });
  return 3 * index.size();
}

std::string AstmTable(const FittedMaterial& material, const AstmGrid& grid, size_t* n_values) {
  std::ostringstream s;
  s << "# ASTM E1392-style BRDF table: angles in degrees, BRDF in 1/sr, phi_i = 0; phi_s = 0 "
       "is the specular direction, 180 the retro direction (ASTM E1392 / E2387)\n";
  s << "# no wavelength or polarisation: the colour channels of the fitted model\n";
  for (const auto& line : ExportHeader(material, std::nullopt)) s << "# " << line << "\n";
  s << "theta_i,phi_i,theta_s,phi_s,brdf" << (material.per_channel ? ",brdf_r,brdf_g,brdf_b" : "")
    << "\n";
  *n_values = 0;
  const CheckedModel model(material.model);
  for (double ti : grid.theta_i_deg) {
    for (double ts : grid.theta_s_deg) {
      for (double ps : grid.phi_s_deg) {
        const Angles<double> a{DegToRad(ti), DegToRad(ts), AstmAzimuthToGonio(DegToRad(ps))};
        double v[3];
        for (int c = 0; c < 3; ++c) {
          const std::string why = model(material.channel_params[c], a, &v[c]);
          if (!why.empty()) {
            throw NumericalError(fmt::format("astm: {} at theta_i {} theta_s {} phi_s {} deg: {}",
                                             material.model, ti, ts, ps, why));
          }
        }
        s << fmt::format("{},0,{},{},{:.9g}", ti, ts, ps, (v[0] + v[1] + v[2]) / 3);
        if (material.per_channel) s << fmt::format(",{:.9g},{:.9g},{:.9g}", v[0], v[1], v[2]);
        s << "\n";
        ++*n_values;
      }
    }
  }
  return s.str();
}

}  // namespace gonio
