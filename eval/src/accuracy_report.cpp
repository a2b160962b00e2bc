// writeAccuracyReport: the sweep as CSV, JSON, Markdown and a PNG plot (accuracy.h).
// The plot is drawn here with a 5x7 bitmap font: no plotting library in the baker's dependencies.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>

#include <nlohmann/json.hpp>

#include "drtv/worlds/summary.h"
#include "drtv/eval/accuracy.h"
#include "drtv/eval/topdown.h"

namespace drtv::eval {
namespace {

namespace fs = std::filesystem;

std::string num(double v, int precision = 4) {
  if (!std::isfinite(v)) return "";
  std::ostringstream s;
  s.precision(precision);
  s << v;
  return s.str();
}

std::string fixed(double v, int decimals) {
  if (!std::isfinite(v)) return "—";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

std::string csvField(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

std::string rangeText(const raytrace::SectorRange& r) {
  return "x " + std::to_string(r.x0) + ".." + std::to_string(r.x1) + ", y " + std::to_string(r.y0) + ".." + std::to_string(r.y1);
}

Result<void> writeText(const fs::path& path, const std::string& text) {
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  if (!f) return fail(path.string() + ": cannot open for writing");
  f << text;
  if (!f) return fail(path.string() + ": write failed");
  return {};
}

// ---- The plot ------------------------------------------------------------------------------

const std::array<image::Rgb, 8> kPalette = {image::Rgb{31, 119, 180}, {255, 127, 14}, {44, 160, 44}, {214, 39, 40},
                                             {148, 103, 189},           {140, 86, 75},  {227, 119, 194}, {127, 127, 127}};

std::string tickLabel(double v) {
  char buf[32];
  if (v >= 1e6) std::snprintf(buf, sizeof buf, "%gM", v / 1e6);
  else if (v >= 1e3) std::snprintf(buf, sizeof buf, "%gK", v / 1e3);
  else std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

// One panel: relative error (%) against x on a log axis.
void panel(image::Canvas& cv, int ox, int oy, int w, int h, const std::string& title, const std::string& xlabel,
           const AccuracyReport& r, double (*xof)(const AccuracyRow&), const std::vector<std::string>& knobs, double ymax) {
  const int left = 44, right = 10, top = 18, bottom = 34;
  const int px0 = ox + left, px1 = ox + w - right, py0 = oy + top, py1 = oy + h - bottom;
  cv.text(ox + left, oy + 4, title, {0, 0, 0});
  double xmin = 1e300, xmax = -1e300;
  for (const AccuracyRow& row : r.rows) {
    const double x = xof(row);
    if (!(x > 0) || !std::isfinite(x)) continue;
    xmin = std::min(xmin, x), xmax = std::max(xmax, x);
  }
  if (!(xmin <= xmax)) xmin = 1, xmax = 10;
  double lx0 = std::floor(std::log10(xmin)), lx1 = std::ceil(std::log10(xmax));
  if (lx1 <= lx0) lx1 = lx0 + 1;
  auto X = [&](double x) { return px0 + int(std::lround((std::log10(x) - lx0) / (lx1 - lx0) * (px1 - px0))); };
  auto Y = [&](double e) { return py1 - int(std::lround(e / ymax * (py1 - py0))); };
  // Grid, axes and ticks.
  for (int d = int(lx0); d <= int(lx1); ++d) {
    const int x = X(std::pow(10.0, d));
    cv.line(x, py0, x, py1, {225, 225, 225});
    const std::string t = tickLabel(std::pow(10.0, d));
    cv.text(x - 3 * int(t.size()), py1 + 4, t);
  }
  for (int k = 0; k <= 4; ++k) {
    const double e = ymax * k / 4;
    const int y = Y(e);
    cv.line(px0, y, px1, y, {225, 225, 225});
    const std::string t = num(100 * e, 3) + "%";
    cv.text(px0 - 4 - 6 * int(t.size()), y - 3, t);
  }
  cv.line(px0, py0, px0, py1, {0, 0, 0});
  cv.line(px0, py1, px1, py1, {0, 0, 0});
  cv.text(px0 + (px1 - px0) / 2 - 3 * int(xlabel.size()), py1 + 16, xlabel);
  // Each knob's rows joined in table order, the default ringed in black.
  for (size_t k = 0; k < knobs.size(); ++k) {
    const image::Rgb c = kPalette[k % kPalette.size()];
    int lxp = -1, lyp = -1;
    for (const AccuracyRow& row : r.rows) {
      if (row.knob != knobs[k]) continue;
      const double x = xof(row);
      if (!(x > 0) || !std::isfinite(x) || !std::isfinite(row.rel_error)) continue;
      const int xp = X(x), yp = Y(std::min(row.rel_error, ymax));
      if (lxp >= 0) cv.line(lxp, lyp, xp, yp, c);
      lxp = xp, lyp = yp;
    }
    for (const AccuracyRow& row : r.rows) {
      if (row.knob != knobs[k]) continue;
      const double x = xof(row);
      if (!(x > 0) || !std::isfinite(x) || !std::isfinite(row.rel_error)) continue;
      const int xp = X(x), yp = Y(std::min(row.rel_error, ymax));
      if (row.is_default) cv.fill(xp - 4, yp - 4, xp + 4 + 1, yp + 4 + 1, {0, 0, 0});
      cv.fill(xp - 3, yp - 3, xp + 3 + 1, yp + 3 + 1, c);
    }
  }
}

image::RgbImage plot(const AccuracyReport& r) {
  std::vector<std::string> knobs;
  double ymax = 0;
  for (const AccuracyRow& row : r.rows) {
    if (std::find(knobs.begin(), knobs.end(), row.knob) == knobs.end()) knobs.push_back(row.knob);
    if (std::isfinite(row.rel_error)) ymax = std::max(ymax, row.rel_error);
  }
  // Four round ticks: the smallest of 0.5%, 1%, 2%, 2.5%, 5%, 10%, 25%, 50%, 100%... covering it.
  double tick = 0.005;
  for (double t : {0.005, 0.01, 0.02, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 5.0, 10.0}) {
    tick = t;
    if (4 * t >= ymax) break;
  }
  ymax = 4 * tick;
  const int pw = 400, ph = 330, legend = 40;
  image::Canvas cv(3 * pw, ph + legend + 24, {255, 255, 255});
  cv.text(8, 6, "drtv accuracy: " + r.world + " - relative error against the path-traced reference", {0, 0, 0});
  panel(cv, 0, 24, pw, ph, "error vs bake time", "bake s", r, [](const AccuracyRow& x) { return x.bake_s; }, knobs, ymax);
  panel(cv, pw, 24, pw, ph, "error vs relight + fill time", "relight + fill ms", r,
        [](const AccuracyRow& x) { return x.relight_fill_ms; }, knobs, ymax);
  panel(cv, 2 * pw, 24, pw, ph, "error vs memory", "probe + volume bytes", r,
        [](const AccuracyRow& x) { return double(x.probe_bytes + x.volume_bytes); }, knobs, ymax);
  int x = 44;
  const int y = 24 + ph + 12;
  for (size_t k = 0; k < knobs.size(); ++k) {
    cv.fill(x, y, x + 8 + 1, y + 6 + 1, kPalette[k % kPalette.size()]);
    x += 14 + cv.text(x + 12, y, knobs[k]) + 12;
  }
  cv.fill(x, y - 1, x + 8 + 1, y + 7 + 1, {0, 0, 0});
  cv.fill(x + 1, y, x + 7 + 1, y + 6 + 1, {255, 255, 255});
  cv.text(x + 12, y, "default");
  return cv.take();
}

}  // namespace

Result<void> writeAccuracyReport(const AccuracyReport& r, const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return fail(dir.string() + ": cannot create: " + ec.message());

  // CSV
  std::string csv = "knob,value,default,rel_error,bias,abs_error,bake_s,relight_fill_ms,probe_bytes,volume_bytes,note\n";
  for (const AccuracyRow& row : r.rows)
    csv += csvField(row.knob) + "," + csvField(row.value) + "," + (row.is_default ? "1" : "0") + "," + num(row.rel_error, 6) + "," +
           num(row.bias, 6) + "," + num(row.abs_error, 6) + "," + num(row.bake_s, 5) + "," + num(row.relight_fill_ms, 5) + "," + std::to_string(row.probe_bytes) +
           "," + std::to_string(row.volume_bytes) + "," + csvField(row.note) + "\n";
  if (auto w = writeText(dir / "accuracy.csv", csv); !w) return w;

  // Per point and hour, the default DRTV row beside the reference.
  std::string pts = "hour,x,y,z,nx,ny,nz,category,ref_r,ref_g,ref_b,drtv_r,drtv_g,drtv_b\n";
  for (const AccuracyPoint& p : r.point_values) {
    pts += num(p.hour, 3) + "," + num(p.position.x, 8) + "," + num(p.position.y, 8) + "," + num(p.position.z, 8) + "," + num(p.normal.x, 4) +
           "," + num(p.normal.y, 4) + "," + num(p.normal.z, 4) + "," + surfaceCategoryName(p.category);
    for (int c = 0; c < 3; ++c) pts += "," + num(p.reference[c], 6);
    for (int c = 0; c < 3; ++c) pts += "," + num(p.drtv[c], 6);
    pts += "\n";
  }
  if (auto w = writeText(dir / "accuracy-points.csv", pts); !w) return w;

  // JSON
  nlohmann::json j;
  j["world"] = r.world;
  j["sectors"] = {{"x0", r.sectors.x0}, {"x1", r.sectors.x1}, {"y0", r.sectors.y0}, {"y1", r.sectors.y1}};
  j["points"] = r.points;
  j["dynamic_points"] = r.dynamic_points;
  j["hours"] = r.hours;
  j["reference"] = {{"samples", r.reference_samples}, {"seconds", r.reference_s}, {"noise", r.reference_noise},
                    {"mean_ambient", {r.reference_mean.x, r.reference_mean.y, r.reference_mean.z}}};
  j["emulation_check"] = r.emulation_check;
  j["wall_s"] = r.wall_s;
  j["skipped"] = r.skipped;
  j["notes"] = r.notes;
  nlohmann::json rows = nlohmann::json::array();
  auto orNull = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  for (const AccuracyRow& row : r.rows)
    rows.push_back({{"knob", row.knob}, {"value", row.value}, {"default", row.is_default}, {"rel_error", orNull(row.rel_error)},
                    {"bias", orNull(row.bias)}, {"abs_error", orNull(row.abs_error)}, {"bake_s", orNull(row.bake_s)}, {"relight_fill_ms", orNull(row.relight_fill_ms)},
                    {"probe_bytes", row.probe_bytes}, {"volume_bytes", row.volume_bytes}, {"note", row.note}});
  for (size_t i = 0; i < r.rows.size(); ++i) {
    nlohmann::json cats = nlohmann::json::object();
    for (int c = 0; c < kSurfaceCategoryCount; ++c) {
      const CategoryError& e = r.rows[i].categories[size_t(c)];
      if (e.points == 0) continue;
      cats[surfaceCategoryName(SurfaceCategory(c))] = {{"points", e.points}, {"rel_error", orNull(e.rel)}, {"bias", orNull(e.bias)},
                                                        {"abs_error", orNull(e.abs)}, {"floored", e.floored}};
    }
    rows[i]["categories"] = cats;
  }
  j["rows"] = rows;
  nlohmann::json cp = nlohmann::json::object();
  for (int c = 0; c < kSurfaceCategoryCount; ++c) cp[surfaceCategoryName(SurfaceCategory(c))] = r.category_points[size_t(c)];
  j["category_points"] = cp;
  j["stratified"] = r.stratified;
  if (auto w = writeText(dir / "accuracy.json", j.dump(2) + "\n"); !w) return w;

  // Markdown
  std::ostringstream md;
  md << "## " << r.world << "\n\n";
  md << "Sectors " << rangeText(r.sectors) << "; " << r.points << " sample points (" << r.dynamic_points
     << " on dynamic objects) at hours";
  for (double h : r.hours) md << " " << num(h);
  md << ". Reference: " << r.reference_samples << " paths per point and hour, " << fixed(r.reference_s, 1)
     << " s, noise " << fixed(100 * r.reference_noise, 2) << "% (sum of standard errors / sum), mean ambient ("
     << fixed(r.reference_mean.x, 3) << ", " << fixed(r.reference_mean.y, 3) << ", " << fixed(r.reference_mean.z, 3)
     << "). Emulated 8-bit volume vs the runtime: " << fixed(100 * r.emulation_check, 2) << "% apart. Wall time "
     << fixed(r.wall_s, 1) << " s.\n\n";
  md << "| knob | value | rel. error | bias | bake s | relight + fill ms | probe KB | volume KB | note |\n";
  md << "|---|---|---:|---:|---:|---:|---:|---:|---|\n";
  for (const AccuracyRow& row : r.rows)
    md << "| " << row.knob << " | " << (row.is_default ? "**" + row.value + "**" : row.value) << " | "
       << fixed(100 * row.rel_error, 1) << "% | " << (row.bias >= 0 ? "+" : "") << fixed(100 * row.bias, 1) << "% | "
       << fixed(row.bake_s, 2) << " | " << fixed(row.relight_fill_ms, 2) << " | " << fixed(row.probe_bytes / 1024.0, 1) << " | "
       << fixed(row.volume_bytes / 1024.0, 0) << " | " << row.note << " |\n";
  // By surface category (accuracy.h, SurfaceCategory): the default configuration, the placement
  // rows and every technique, each category's error, bias and share of the points, and the worst.
  md << "\nBy surface category (points:";
  for (int c = 0; c < kSurfaceCategoryCount; ++c)
    md << " " << surfaceCategoryName(SurfaceCategory(c)) << " " << r.category_points[size_t(c)] << " ("
       << fixed(100.0 * double(r.category_points[size_t(c)]) / double(std::max<size_t>(r.points, 1)), 0) << "%)";
  md << "); rel. error (bias):\n\n| row |";
  for (int c = 0; c < kSurfaceCategoryCount; ++c) md << " " << surfaceCategoryName(SurfaceCategory(c)) << " |";
  md << " worst |\n|---|";
  for (int c = 0; c < kSurfaceCategoryCount; ++c) md << "---:|";
  md << "---|\n";
  for (const AccuracyRow& row : r.rows) {
    // The rows the techniques mark (KnobRow::by_category: those that move probes or light
    // indoors), each technique at its defaults, and the default configuration.
    const bool is_default_row = row.knob == "rays_per_basis" && row.is_default;
    if (!(row.knob == "technique" || !row.by_category.empty() || is_default_row)) continue;
    md << "| " << (row.knob == "technique" ? row.value : !row.by_category.empty() ? row.by_category : std::string("default")) << " |";
    int worst = -1;
    for (int c = 0; c < kSurfaceCategoryCount; ++c) {
      const CategoryError& e = row.categories[size_t(c)];
      if (e.points == 0) {
        md << " — |";
        continue;
      }
      md << " " << fixed(100 * e.rel, 1) << "% (" << (e.bias >= 0 ? "+" : "") << fixed(100 * e.bias, 1) << "%) |";
      if (worst < 0 || e.rel > row.categories[size_t(worst)].rel) worst = c;
    }
    md << " " << (worst < 0 ? "—" : surfaceCategoryName(SurfaceCategory(worst))) << " |\n";
  }
  for (const std::string& s : r.skipped) md << "\nSkipped: " << s << ".\n";
  for (const std::string& s : worlds::collapseNotes(r.notes)) md << "\nNote: " << s << "\n";
  if (auto w = writeText(dir / "accuracy.md", md.str()); !w) return w;

  return image::writePng(dir / "accuracy.png", plot(r));
}

}  // namespace drtv::eval
