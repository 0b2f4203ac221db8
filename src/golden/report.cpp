// What people look at: region and difference images, the HTML report, and the PNG readers.
#include <png.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <penumbra/core/error.hpp>
#include <penumbra/core/file.hpp>
#include <penumbra/golden/golden.hpp>
#include <penumbra/reference/metrics.hpp>
#include <penumbra/render/renderer.hpp>
#include <sstream>
#include <system_error>

namespace penumbra::golden {
namespace fs = std::filesystem;

// ---- PNG (libpng's simplified API) ------------------------------------------------------------
void write_png16(const fs::path& path, uint32_t width, uint32_t height,
                 const std::vector<float>& values) {
  if (values.size() != size_t(width) * height)
    throw Error("write_png16 " + path.string() + ": " + std::to_string(values.size()) +
                " values for " + std::to_string(width) + "x" + std::to_string(height));
  std::vector<png_uint_16> px(values.size());
  for (size_t i = 0; i < values.size(); ++i) {
    const float v = std::isfinite(values[i]) ? std::clamp(values[i], 0.0f, 1.0f) : 0.0f;
    px[i] = png_uint_16(std::lround(v * 65535.0f));
  }
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  image.width = width;
  image.height = height;
  image.format = PNG_FORMAT_LINEAR_Y;  // 16-bit grey, written as is with a linear gAMA
  png_alloc_size_t size = 0;
  if (!png_image_write_to_memory(&image, nullptr, &size, 0, px.data(), 0, nullptr))
    throw Error("write_png16 " + path.string() + ": " + image.message);
  std::string bytes(size, '\0');
  if (!png_image_write_to_memory(&image, bytes.data(), &size, 0, px.data(), 0, nullptr))
    throw Error("write_png16 " + path.string() + ": " + image.message);
  bytes.resize(size);
  write_file_atomic(path, bytes);
}

namespace {

template <typename T>
std::vector<T> read_png(const fs::path& path, uint32_t format, uint32_t channels, uint32_t& w,
                        uint32_t& h) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&image, path.string().c_str()))
    throw Error("cannot read " + path.string() + ": " + image.message);
  image.format = format;
  std::vector<T> px(size_t(image.width) * image.height * channels);
  if (!png_image_finish_read(&image, nullptr, px.data(), 0, nullptr)) {
    const std::string msg = image.message;
    png_image_free(&image);
    throw Error("cannot read " + path.string() + ": " + msg);
  }
  w = image.width;
  h = image.height;
  return px;
}

}  // namespace

std::vector<float> read_png16(const fs::path& path, uint32_t& w, uint32_t& h) {
  const auto px = read_png<png_uint_16>(path, PNG_FORMAT_LINEAR_Y, 1, w, h);
  std::vector<float> out(px.size());
  for (size_t i = 0; i < px.size(); ++i) out[i] = float(px[i]) / 65535.0f;
  return out;
}

std::vector<uint8_t> read_png_rgba8(const fs::path& path, uint32_t& w, uint32_t& h) {
  return read_png<uint8_t>(path, PNG_FORMAT_RGBA, 4, w, h);
}

// ---- images ---------------------------------------------------------------------------------
namespace {

uint8_t grey_of(const std::vector<uint8_t>& rgba, size_t i) {
  return uint8_t((int(rgba[i * 4]) * 3 + int(rgba[i * 4 + 1]) * 6 + int(rgba[i * 4 + 2])) / 10);
}

// Black → red → yellow → white over t in [0, 1].
void heat(float t, uint8_t* out) {
  t = std::clamp(t, 0.0f, 1.0f) * 3.0f;
  out[0] = uint8_t(255.0f * std::min(t, 1.0f));
  out[1] = uint8_t(255.0f * std::clamp(t - 1.0f, 0.0f, 1.0f));
  out[2] = uint8_t(255.0f * std::clamp(t - 2.0f, 0.0f, 1.0f));
  out[3] = 255;
}

std::vector<reference::ReceiverClass> compared(const std::vector<Region>& regions) {
  std::vector<reference::ReceiverClass> c(regions.size(), reference::ReceiverClass::none);
  for (size_t i = 0; i < regions.size(); ++i)
    if (regions[i] != Region::none) c[i] = reference::ReceiverClass::lit;
  return c;
}

}  // namespace

std::vector<uint8_t> region_image(const std::vector<Region>& regions,
                                  const std::vector<uint8_t>& frame) {
  std::vector<uint8_t> out(regions.size() * 4);
  for (size_t i = 0; i < regions.size(); ++i) {
    const float g = float(i * 4 < frame.size() ? grey_of(frame, i) : 128) / 255.0f;
    float c[3] = {g * 0.6f, g * 0.6f, g * 0.6f};
    auto tint = [&](float r, float gg, float b) {
      c[0] = 0.35f * c[0] + 0.65f * r;
      c[1] = 0.35f * c[1] + 0.65f * gg;
      c[2] = 0.35f * c[2] + 0.65f * b;
    };
    switch (regions[i]) {
      case Region::umbra:
        tint(0.15f, 0.3f, 1.0f);
        break;
      case Region::penumbra:
        tint(1.0f, 0.55f, 0.1f);
        break;
      case Region::silhouette:
        tint(0.95f, 0.1f, 0.9f);
        break;
      case Region::lit:
        tint(1.0f, 1.0f, 0.7f);
        break;
      case Region::none:
        break;
    }
    for (int ch = 0; ch < 3; ++ch) out[i * 4 + size_t(ch)] = uint8_t(255.0f * c[ch]);
    out[i * 4 + 3] = 255;
  }
  return out;
}

std::vector<uint8_t> visibility_difference_image(const std::vector<float>& expected,
                                                 const std::vector<float>& actual,
                                                 const std::vector<Region>& regions,
                                                 const std::vector<uint8_t>& frame) {
  const size_t n = actual.size();
  std::vector<uint8_t> out(n * 4, 255);
  for (size_t i = 0; i < n; ++i) {
    const uint8_t g = uint8_t(i * 4 < frame.size() ? grey_of(frame, i) / 4 : 32);
    const bool compared = i < regions.size() && regions[i] != Region::none && i < expected.size();
    const float d = compared ? actual[i] - expected[i] : 0.0f;
    if (!std::isfinite(d)) {  // NaN or inf in the new frame: magenta
      out[i * 4] = 255;
      out[i * 4 + 1] = 0;
      out[i * 4 + 2] = 255;
      continue;
    }
    if (std::abs(d) < 1.0f / 1024.0f) {
      out[i * 4] = out[i * 4 + 1] = out[i * 4 + 2] = g;
      continue;
    }
    const float t = std::clamp(0.25f + 3.0f * std::abs(d), 0.0f, 1.0f);
    const float base = float(g) * (1.0f - t);
    out[i * 4] = uint8_t(base + (d > 0 ? 255.0f * t : 40.0f * t));
    out[i * 4 + 1] = uint8_t(base + 40.0f * t);
    out[i * 4 + 2] = uint8_t(base + (d > 0 ? 40.0f * t : 255.0f * t));
  }
  return out;
}

std::vector<uint8_t> frame_difference_image(const Frame& e, const Frame& a) {
  const size_t n = size_t(a.width) * a.height;
  std::vector<uint8_t> out(n * 4, 0);
  if (e.lit.size() != a.lit.size()) return out;
  for (size_t i = 0; i < n; ++i) {
    int d = 0;
    for (int ch = 0; ch < 3; ++ch)
      d = std::max(d, std::abs(int(e.lit[i * 4 + size_t(ch)]) - int(a.lit[i * 4 + size_t(ch)])));
    if (d == 0) {
      const uint8_t g = uint8_t(grey_of(a.lit, i) / 4);
      out[i * 4] = out[i * 4 + 1] = out[i * 4 + 2] = g;
      out[i * 4 + 3] = 255;
    } else {
      heat(0.1f + 0.9f * float(d) / 32.0f, &out[i * 4]);
    }
  }
  return out;
}

// ---- the report -----------------------------------------------------------------------------
namespace {

std::string html_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '<')
      out += "&lt;";
    else if (c == '>')
      out += "&gt;";
    else if (c == '&')
      out += "&amp;";
    else if (c == '"')
      out += "&quot;";
    else
      out += c;
  }
  return out;
}

const LightImage* find_light(const Frame& f, const std::string& name) {
  for (const auto& l : f.lights)
    if (l.light == name) return &l;
  return nullptr;
}

}  // namespace

fs::path write_report(const fs::path& dir, const ReportInfo& info,
                      const std::optional<Frame>& expected, const Frame& actual,
                      const std::optional<Comparison>& comparison) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw Error("cannot create " + dir.string() + ": " + ec.message());
  auto png = [&](const std::string& name, const Frame& f, const std::vector<uint8_t>& rgba) {
    render::write_png(dir / name, f.width, f.height, rgba);
    return name;
  };
  std::ostringstream h;
  h << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n<title>"
    << html_escape(info.title) << "</title>\n<style>\n"
    << "body{font:14px system-ui,sans-serif;margin:1.5em;background:#fafafa;color:#222}\n"
    << "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;padding:2px "
       "8px;text-align:right}th{background:#eee}td.l{text-align:left}\n"
    << "tr.fail td{background:#fdd}tr.ok td.v{color:#070}tr.fail td.v{color:#b00;font-weight:"
       "bold}\n"
    << ".row{display:flex;flex-wrap:wrap;gap:12px}figure{margin:0}figure img{max-width:"
       "480px;width:100%;image-rendering:pixelated;border:1px solid #999}\n"
    << "figcaption{font-size:12px;color:#555}\n.verdict{font-size:20px;font-weight:bold}"
       ".pass{color:#070}.failed{color:#b00}\n</style></head><body>\n";
  h << "<h1>" << html_escape(info.title) << "</h1>\n<p>" << html_escape(info.subtitle)
    << "</p>\n";
  if (comparison) {
    const bool ok = comparison->passed();
    h << "<p class=\"verdict " << (ok ? "pass\">PASSED" : "failed\">FAILED") << "</p>\n";
    for (const auto& s : comparison->structural)
      h << "<p class=\"failed\">" << html_escape(s) << "</p>\n";
    h << "<table><tr><th>image</th><th>region</th><th>pixels</th><th>over</th><th>allowed</th>"
         "<th>tolerance</th><th>worst</th><th>at</th><th>expected</th><th>actual</th>"
         "<th>verdict</th></tr>\n";
    for (const auto& r : comparison->results) {
      char row[600];
      std::snprintf(row, sizeof row,
                    "<tr class=\"%s\"><td class=\"l\">%s</td><td class=\"l\">%s</td><td>%llu</td>"
                    "<td>%llu</td><td>%llu</td><td>%.3f</td><td>%.3f</td><td>(%u, %u)</td>"
                    "<td>%.3f</td><td>%.3f</td><td class=\"v\">%s</td></tr>\n",
                    r.passed() ? "ok" : "fail", html_escape(r.image).c_str(),
                    html_escape(r.region).c_str(), (unsigned long long)r.pixels,
                    (unsigned long long)r.over, (unsigned long long)r.allowed,
                    double(r.tolerance.max_diff), double(r.worst), r.worst_x, r.worst_y,
                    double(r.expected), double(r.actual), r.passed() ? "ok" : "FAIL");
      h << row;
    }
    h << "</table>\n";
  }
  auto figure = [&](const std::string& file, const std::string& caption) {
    h << "<figure><a href=\"" << file << "\"><img src=\"" << file << "\" alt=\""
      << html_escape(caption) << "\"></a><figcaption>" << html_escape(caption)
      << "</figcaption></figure>\n";
  };
  h << "<h2>frame</h2>\n<div class=\"row\">\n";
  if (expected) figure(png("expected-lit.png", *expected, expected->lit), info.before_label);
  figure(png("actual-lit.png", actual, actual.lit), info.after_label);
  if (expected && expected->lit.size() == actual.lit.size())
    figure(png("difference-lit.png", actual, frame_difference_image(*expected, actual)),
           "difference (black: none; red → white: 1 → 32+ levels)");
  h << "</div>\n";
  for (const auto& al : actual.lights) {
    const LightImage* el = expected ? find_light(*expected, al.light) : nullptr;
    // Regions: the golden's, or (no golden) the new frame's own if it has them.
    const std::vector<Region>& regions =
        el && el->regions.size() == al.visibility.size() ? el->regions : al.regions;
    const std::vector<Region> everywhere(al.visibility.size(), Region::lit);
    const auto classes = compared(regions.empty() ? everywhere : regions);
    h << "<h2>" << html_escape(al.light) << " visibility</h2>\n<div class=\"row\">\n";
    if (el && el->visibility.size() == al.visibility.size())
      figure(png("expected-" + al.light + ".png", actual,
                 reference::visibility_image(el->visibility, classes, actual.lit)),
             info.before_label);
    figure(png("actual-" + al.light + ".png", actual,
               reference::visibility_image(al.visibility, classes, actual.lit)),
           info.after_label);
    if (el && el->visibility.size() == al.visibility.size())
      figure(png("difference-" + al.light + ".png", actual,
                 visibility_difference_image(el->visibility, al.visibility, regions, actual.lit)),
             "difference: lighter than expected red, darker blue (full at 0.25)");
    if (!regions.empty())
      figure(png("regions-" + al.light + ".png", actual, region_image(regions, actual.lit)),
             "regions: umbra blue, penumbra orange, silhouette magenta, lit yellow");
    h << "</div>\n";
  }
  h << "</body></html>\n";
  const fs::path index = dir / "index.html";
  write_file_atomic(index, h.str());
  return index;
}

}  // namespace penumbra::golden
