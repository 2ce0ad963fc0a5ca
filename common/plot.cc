#include "common/plot.h"

#include <cstdlib>
#include <fstream>
#include <sstream>

#include "common/error.h"
#include "common/io.h"

namespace fs = std::filesystem;

namespace gonio {

std::string GnuplotQuote(const std::string& s) {
  std::string q = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') q += '\\';
    q += c;
  }
  return q + "\"";
}

void RenderPlot(const PlotSpec& spec, const fs::path& out) {
  const std::string ext = out.extension().string();
  std::string terminal;
  if (ext == ".png") {
    terminal = "pngcairo size " + std::to_string(spec.width) + "," + std::to_string(spec.height) +
               " font 'Sans,11'";
  } else if (ext == ".svg") {
    terminal =
        "svg size " + std::to_string(spec.width) + "," + std::to_string(spec.height) + " dynamic";
  } else {
    throw InputError(out.string() + ": plots are written as .png or .svg");
  }
  WriteAtomically(out, [&](const fs::path& tmp) {
    const fs::path data = fs::path(tmp).replace_extension(".dat");
    const fs::path script = fs::path(tmp).replace_extension(".gp");
    {
      std::ofstream d(data);
      for (const auto& s : spec.series) {
        for (size_t k = 0; k < s.x.size() && k < s.y.size(); ++k)
          d << s.x[k] << ' ' << s.y[k] << '\n';
        d << "\n\n";  // gnuplot data block separator: addressed by "index k"
      }
    }
    std::ostringstream gp;
    gp << "set terminal " << terminal << "\n";
    gp << "set output " << GnuplotQuote(tmp.string()) << "\n";
    gp << "set title " << GnuplotQuote(spec.title) << " noenhanced\n";
    gp << "set xlabel " << GnuplotQuote(spec.xlabel) << " noenhanced\n";
    gp << "set ylabel " << GnuplotQuote(spec.ylabel) << " noenhanced\n";
    gp << "set grid\nset key outside right top noenhanced\n";
    if (spec.log_x) gp << "set logscale x\n";
    if (spec.log_y) gp << "set logscale y\n";
    gp << spec.extra << "\n";
    // With no series, `extra` carries its own plot/splot command (3-D sketches, heat maps).
    if (!spec.series.empty()) gp << "plot ";
    for (size_t k = 0; k < spec.series.size(); ++k) {
      if (k) gp << ", \\\n     ";
      gp << GnuplotQuote(data.string()) << " index " << k << " using 1:2 with "
         << spec.series[k].style << " title " << GnuplotQuote(spec.series[k].label);
    }
    gp << "\n";
    {
      std::ofstream s(script);
      s << gp.str();
    }
    const std::string cmd = "gnuplot " + GnuplotQuote(script.string()) + " 2>" +
                            GnuplotQuote(fs::path(tmp).replace_extension(".log").string());
    const int rc = std::system(cmd.c_str());
    std::error_code ec;
    fs::remove(data, ec);
    fs::remove(script, ec);
    fs::remove(fs::path(tmp).replace_extension(".log"), ec);
    if (rc != 0) {
      throw InputError(out.string() +
                       ": gnuplot failed (is gnuplot-nox installed? run scripts/setup)");
    }
    return fs::exists(tmp);
  });
}

}  // namespace gonio
