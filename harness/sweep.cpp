#include "harness/sweep.hpp"

#include <algorithm>
#include <cstdio>
#include <map>
#include <set>

#include "core/error.hpp"
#include "core/text.hpp"
#include "denoisers/params.hpp"
#include "harness/scene_selection.hpp"

namespace arena {

RunConfig sweepRun(RunConfig c, const std::string& denoiser,
                   const std::map<std::string, std::string>& fixed,
                   const std::vector<std::string>& grids, size_t maxPoints) {
  const DenoiserInfo& info = DenoiserRegistry::instance().find(denoiser);
  std::vector<std::pair<std::string, std::vector<std::string>>> axes;
  for (const std::string& written : grids) {
    // Spaces around the name, the '=' and the brackets are layout (those inside the list are too).
    std::string g = trimmed(written);
    if (const size_t at = g.find('='); at != std::string::npos)
      g = trimmed(g.substr(0, at)) + "=" + trimmed(g.substr(at + 1));
    const size_t eq = g.find('=');
    if (eq == std::string::npos || g.size() < eq + 3 || g[eq + 1] != '[' || g.back() != ']')
      throw Error("--grid '" + written + "': expected NAME=[v1,v2,...]");
    std::string name = g.substr(0, eq);
    if (name.rfind(denoiser + ".", 0) == 0) name = name.substr(denoiser.size() + 1);
    if (!info.schema.find(name)) info.schema.resolve({{name, ""}}, denoiser);  // throws, listing names
    for (auto& [axis, values] : axes)
      if (axis == name)
        throw Error("--grid '" + written + "': " + name + " is already an axis of this sweep");
    if (fixed.count(name))
      throw Error("--grid '" + written + "': " + name + " is also fixed by --param");
    const std::string inner = g.substr(eq + 2, g.size() - eq - 3);
    // "[1,,2]" is a value left out, not a list of two: said, not read as [1,2].
    if (inner.empty())
      throw Error("--grid '" + written + "': no values; expected NAME=[v1,v2,...]");
    axes.push_back(
        {name, splitList(inner, "--grid '" + written + "': values", "NAME=[v1,v2,...]")});
    // Compared as the denoiser reads them ("2" and "2.0", "0" and "-0" are one setting: two
    // contenders of one setting would only add ties), each value checked on the way. A built-in
    // reads a float parameter as a float, so values that round to one float are one setting too
    // (its schema resolves them to one value).
    std::map<std::string, std::string> distinct;  // as read -> as written
    for (const std::string& v : axes.back().second) {
      const std::string key =
          ParamSet::text(info.schema.resolve({{name, v}}, denoiser).values().at(name));
      if (auto [it, added] = distinct.emplace(key, v); !added)
        throw Error("--grid '" + written + "': " + it->second + " and " + v +
                    " are the same value of " + name + " (as " + denoiser + " reads it: " + key +
                    ")");
    }
  }
  double points = 1;  // in double: no overflow however many axes
  std::string product;
  for (auto& [name, values] : axes) {
    points *= double(values.size());
    product += (product.empty() ? "" : " x ") + std::to_string(values.size());
  }
  if (points > double(maxPoints)) {
    char count[32];
    std::snprintf(count, sizeof count, "%.0f", points);
    throw Error("--grid: " + product + " = " + count + " grid points, more than " +
                std::to_string(maxPoints) +
                " (--max-points), each run on every scene; narrow the "
                "grid, or raise --max-points to run it");
  }
  std::vector<std::map<std::string, std::string>> settings = {fixed};
  for (auto& [name, values] : axes) {
    std::vector<std::map<std::string, std::string>> next;
    for (auto& s : settings)
      for (auto& v : values) {
        auto t = s;
        t[name] = v;
        next.push_back(t);
      }
    settings = next;
  }
  nlohmann::json grid = nlohmann::json::object();
  for (auto& [name, values] : axes) grid[name] = values;
  // Its points' labels, in the grid's order: the report's ablation tells them from a baseline of
  // the same denoiser, and takes each axis's first value from the first of them.
  nlohmann::json labels = nlohmann::json::array();
  for (auto& s : settings) {
    DenoiserRequest point{denoiser, s, ""};
    point.label = defaultLabel(point);
    labels.push_back(point.label);
    c.denoisers.push_back(point);
  }
  c.annotations["sweep"] = {
      {"denoiser", denoiser}, {"grid", grid}, {"fixed", fixed}, {"labels", labels}};
  return c;
}

}  // namespace arena
