#include "export/export.h"

#include <cmath>
#include <sstream>

#include <fmt/format.h>

#include "common/error.h"
#include "common/io.h"
#include "common/math.h"
#include "common/option_words.h"
#include "common/provenance.h"

namespace gonio {
namespace {

// One word table for both directions (common/option_words.h).
constexpr OptionWord<ExportFormat> kFormatWords[] = {
    {ExportFormat::kMitsuba, "mitsuba"}, {ExportFormat::kPbrt3, "pbrt3"},
    {ExportFormat::kBlender, "blender"}, {ExportFormat::kMaterialx, "materialx"},
    {ExportFormat::kAstm, "astm"},       {ExportFormat::kMerl, "merl"}};

std::string RendererName(RendererFunction f) {
  switch (f) {
    case RendererFunction::kOrenNayar:
      return "Mitsuba 0.6 roughdiffuse (useFastApprox false = Oren-Nayar eq. 27-29)";
    case RendererFunction::kOrenNayarQualitative:
      return "pbrt-v3 matte (OrenNayar, qualitative model eq. 30)";
    case RendererFunction::kCyclesDiffuse:
      return "Blender Cycles Diffuse BSDF (Fujii + multiple scattering, bsdf_oren_nayar.h)";
    case RendererFunction::kMaterialxFujiiEc:
      return "MaterialX oren_nayar_diffuse_bsdf, energy_compensation true (OpenPBR)";
  }
  return "";
}

// XML comments may not contain "--".
std::string XmlComment(const std::vector<std::string>& lines) {
  std::string s = "<!--\n";
  for (std::string l : lines) {
    for (size_t p; (p = l.find("--")) != std::string::npos;) l.replace(p, 2, "- -");
    s += "  " + l + "\n";
  }
  return s + "-->\n";
}

std::string HashComment(const std::vector<std::string>& lines) {
  std::string s;
  for (const auto& l : lines) s += "# " + l + "\n";
  return s;
}

std::string Rgb(const std::array<double, 3>& c, const char* sep) {
  return fmt::format("{:.6g}{}{:.6g}{}{:.6g}", c[0], sep, c[1], sep, c[2]);
}

std::string RendererText(ExportFormat format, const RendererFit& fit,
                         const std::vector<std::string>& header) {
  switch (format) {
    case ExportFormat::kMitsuba:
      return XmlComment(header) + "<bsdf type=\"roughdiffuse\" id=\"gonio\">\n" +
             "  <rgb name=\"reflectance\" value=\"" + Rgb(fit.albedo, ", ") + "\"/>\n" +
             fmt::format("  <float name=\"alpha\" value=\"{:.6g}\"/>\n",
                         std::sqrt(2.0) * fit.shape) +
             "  <boolean name=\"useFastApprox\" value=\"false\"/>\n</bsdf>\n";
    case ExportFormat::kPbrt3:
      return HashComment(header) + "Material \"matte\" \"rgb Kd\" [ " + Rgb(fit.albedo, " ") +
             fmt::format(" ] \"float sigma\" [ {:.6g} ]\n", RadToDeg(fit.shape));
    case ExportFormat::kBlender:
      return HashComment(header) + "# Run in Blender's Python console or: blender -P this.py\n" +
             "import bpy\n\nmat = bpy.data.materials.new(\"gonio_material\")\n" +
             "mat.use_nodes = True\nnodes = mat.node_tree.nodes\n" +
             "for node in list(nodes):\n    nodes.remove(node)\n" +
             "bsdf = nodes.new(\"ShaderNodeBsdfDiffuse\")\n" +
             "bsdf.inputs[\"Color\"].default_value = (" + Rgb(fit.albedo, ", ") + ", 1.0)\n" +
             fmt::format("bsdf.inputs[\"Roughness\"].default_value = {:.6g}\n", fit.shape) +
             "out = nodes.new(\"ShaderNodeOutputMaterial\")\n" +
             "mat.node_tree.links.new(bsdf.outputs[\"BSDF\"], out.inputs[\"Surface\"])\n";
    case ExportFormat::kMaterialx:
      return "<?xml version=\"1.0\"?>\n" + XmlComment(header) +
             "<materialx version=\"1.39\">\n"
             "  <oren_nayar_diffuse_bsdf name=\"gonio_diffuse\" type=\"BSDF\">\n"
             "    <input name=\"color\" type=\"color3\" value=\"" +
             Rgb(fit.albedo, ", ") + "\" />\n" +
             fmt::format("    <input name=\"roughness\" type=\"float\" value=\"{:.6g}\" />\n",
                         fit.shape) +
             "    <input name=\"energy_compensation\" type=\"boolean\" value=\"true\" />\n"
             "  </oren_nayar_diffuse_bsdf>\n"
             "  <surface name=\"gonio_surface\" type=\"surfaceshader\">\n"
             "    <input name=\"bsdf\" type=\"BSDF\" nodename=\"gonio_diffuse\" />\n"
             "  </surface>\n"
             "  <surfacematerial name=\"gonio_material\" type=\"material\">\n"
             "    <input name=\"surfaceshader\" type=\"surfaceshader\" nodename=\"gonio_surface\" "
             "/>\n"
             "  </surfacematerial>\n</materialx>\n";
    default:
      return "";
  }
}

void CheckAngles(const std::vector<double>& v, double max, const char* what) {
  if (v.empty()) throw InputError(std::string(what) + ": empty list");
  for (double d : v) {
    if (!std::isfinite(d) || d < 0 || d > max) {
      throw InputError(fmt::format("{}: {} is outside [0, {}] deg", what, d, max));
    }
  }
}

}  // namespace

ExportFormat ParseExportFormat(const std::string& s) {
  return ParseOptionWord(kFormatWords, s, "--format");
}

std::string FormatName(ExportFormat f) { return OptionWordOf(kFormatWords, f); }

std::optional<RendererFunction> RendererFunctionOf(ExportFormat f) {
  switch (f) {
    case ExportFormat::kMitsuba:
      return RendererFunction::kOrenNayar;
    case ExportFormat::kPbrt3:
      return RendererFunction::kOrenNayarQualitative;
    case ExportFormat::kBlender:
      return RendererFunction::kCyclesDiffuse;
    case ExportFormat::kMaterialx:
      return RendererFunction::kMaterialxFujiiEc;
    default:
      return std::nullopt;
  }
}

void AstmGrid::Check() const {
  CheckAngles(theta_i_deg, 89.9, "--theta-i");
  CheckAngles(theta_s_deg, 89.9, "--theta-s");
  CheckAngles(phi_s_deg, 360, "--phi-s");
}

void ExportOptions::Check() const {
  domain.Check();
  grid.Check();
}

std::vector<std::string> ExportHeader(const FittedMaterial& material,
                                      const std::optional<RendererFit>& renderer) {
  std::vector<std::string> h = {
      fmt::format("gonio {} export{}", Version(),
                  material.source.empty() ? "" : " of " + material.source),
      "fitted material: " + material.Report()};
  if (renderer) {
    h.push_back("target: " + RendererName(renderer->function));
    h.push_back(renderer->Report());
    if (!renderer->exact) {
      h.push_back(
          "the target's function differs from the fitted model: its parameters are "
          "the least-squares best match; the error above is what remains");
    }
  }
  return h;
}

ExportResult ExportMaterial(const FittedMaterial& material, const ExportOptions& options,
                            const std::filesystem::path& out) {
  options.Check();
  ExportResult result;
  result.format = options.format;
  if (const auto function = RendererFunctionOf(options.format)) {
    result.renderer = FitRenderer(*function, material, options.domain);
    WriteTextAtomically(out, RendererText(options.format, *result.renderer,
                                          ExportHeader(material, result.renderer)));
  } else if (options.format == ExportFormat::kAstm) {
    WriteTextAtomically(out, AstmTable(material, options.grid, &result.n_values));
  } else {
    result.n_values = WriteMerlBinary(material, out);
  }
  return result;
}

std::string ExportResult::Report() const {
  if (renderer) return FormatName(format) + ": " + renderer->Report() + "\n";
  return fmt::format("{}: {} values tabulated\n", FormatName(format), n_values);
}

std::string MitsubaTexturedText(const std::vector<std::string>& header,
                                const std::vector<std::string>& t, double side_m) {
  std::vector<std::string> h = header;
  h.push_back(fmt::format(
      "apply to a square of side {:.6g} m with uv over [0, 1]: the height texture is in metres, "
      "so the bump needs no scale; textures are linear PFM",
      side_m));
  return XmlComment(h) + "<bsdf type=\"bumpmap\" id=\"gonio\">\n" +
         "  <texture type=\"bitmap\">\n    <string name=\"filename\" value=\"" + t[2] +
         "\"/>\n  </texture>\n" + "  <bsdf type=\"roughdiffuse\">\n" +
         "    <texture type=\"bitmap\" name=\"reflectance\">\n" +
         "      <string name=\"filename\" value=\"" + t[0] + "\"/>\n    </texture>\n" +
         "    <texture type=\"bitmap\" name=\"alpha\">\n" +
         "      <string name=\"filename\" value=\"" + t[1] + "\"/>\n    </texture>\n" +
         "    <boolean name=\"useFastApprox\" value=\"false\"/>\n  </bsdf>\n</bsdf>\n";
}

std::string BlenderTexturedText(const std::vector<std::string>& header,
                                const std::vector<std::string>& t) {
  return HashComment(header) +
         "# Run in Blender's Python console or: blender -P this.py (textures beside this file)\n"
         "import os\n\nimport bpy\n\n"
         "here = os.path.dirname(os.path.abspath(__file__))\n"
         "mat = bpy.data.materials.new(\"gonio_maps\")\nmat.use_nodes = True\n"
         "nodes = mat.node_tree.nodes\nlinks = mat.node_tree.links\n"
         "for node in list(nodes):\n    nodes.remove(node)\n\n\n"
         "def image(name, colour):\n"
         "    node = nodes.new(\"ShaderNodeTexImage\")\n"
         "    node.image = bpy.data.images.load(os.path.join(here, name))\n"
         "    node.interpolation = \"Cubic\"\n"
         "    # Float textures hold linear values; data (roughness, normals) is not colour.\n"
         "    names = [\"Linear Rec.709\", \"Linear\"] if colour else [\"Non-Color\"]\n"
         "    for n in names:\n"
         "        try:\n"
         "            node.image.colorspace_settings.name = n\n"
         "            break\n"
         "        except TypeError:\n"
         "            pass\n"
         "    return node\n\n\n"
         "base = image(\"" +
         t[0] + "\", True)\n" + "rough = image(\"" + t[1] + "\", False)\n" + "normal = image(\"" +
         t[2] + "\", False)\n" +
         "nmap = nodes.new(\"ShaderNodeNormalMap\")\nnmap.space = \"TANGENT\"\n"
         "bsdf = nodes.new(\"ShaderNodeBsdfDiffuse\")\n"
         "out = nodes.new(\"ShaderNodeOutputMaterial\")\n"
         "links.new(base.outputs[\"Color\"], bsdf.inputs[\"Color\"])\n"
         "links.new(rough.outputs[\"Color\"], bsdf.inputs[\"Roughness\"])\n"
         "links.new(normal.outputs[\"Color\"], nmap.inputs[\"Color\"])\n"
         "links.new(nmap.outputs[\"Normal\"], bsdf.inputs[\"Normal\"])\n"
         "links.new(bsdf.outputs[\"BSDF\"], out.inputs[\"Surface\"])\n";
}

std::string MaterialxTexturedText(const std::vector<std::string>& header,
                                  const std::vector<std::string>& t) {
  return "<?xml version=\"1.0\"?>\n" + XmlComment(header) +
         "<materialx version=\"1.39\">\n"
         "  <image name=\"gonio_basecolor\" type=\"color3\">\n"
         "    <input name=\"file\" type=\"filename\" value=\"" +
         t[0] +
         "\" colorspace=\"lin_rec709\" />\n  </image>\n"
         "  <image name=\"gonio_roughness\" type=\"float\">\n"
         "    <input name=\"file\" type=\"filename\" value=\"" +
         t[1] +
         "\" />\n  </image>\n"
         "  <image name=\"gonio_normal_texture\" type=\"vector3\">\n"
         "    <input name=\"file\" type=\"filename\" value=\"" +
         t[2] +
         "\" />\n  </image>\n"
         "  <normalmap name=\"gonio_normal\" type=\"vector3\">\n"
         "    <input name=\"in\" type=\"vector3\" nodename=\"gonio_normal_texture\" />\n"
         "  </normalmap>\n"
         "  <oren_nayar_diffuse_bsdf name=\"gonio_diffuse\" type=\"BSDF\">\n"
         "    <input name=\"color\" type=\"color3\" nodename=\"gonio_basecolor\" />\n"
         "    <input name=\"roughness\" type=\"float\" nodename=\"gonio_roughness\" />\n"
         "    <input name=\"normal\" type=\"vector3\" nodename=\"gonio_normal\" />\n"
         "    <input name=\"energy_compensation\" type=\"boolean\" value=\"true\" />\n"
         "  </oren_nayar_diffuse_bsdf>\n"
         "  <surface name=\"gonio_surface\" type=\"surfaceshader\">\n"
         "    <input name=\"bsdf\" type=\"BSDF\" nodename=\"gonio_diffuse\" />\n"
         "  </surface>\n"
         "  <surfacematerial name=\"gonio_material\" type=\"material\">\n"
         "    <input name=\"surfaceshader\" type=\"surfaceshader\" nodename=\"gonio_surface\" />\n"
         "  </surfacematerial>\n</materialx>\n";
}

}  // namespace gonio
