#include "calibration/measurements.h"

#include "core/error.h"

namespace rosguard::calibration {
namespace {

using nlohmann::json;

template <typename T>
T field(const json& j, const char* key, const std::string& file, const std::string& path) {
  if (!j.is_object() || !j.contains(key)) throw InputError(file, path + "/" + key, "missing");
  try {
    return j.at(key).get<T>();
  } catch (const json::exception&) {
    throw InputError(file, path + "/" + key, "wrong type");
  }
}

}  // namespace

void to_json(json& j, const Measurements& m) {
  const HostFacts& h = m.host;
  j = json{{"host",
            {{"hostname", h.hostname},
             {"cpu_model", h.cpu_model},
             {"cpus", h.cpus},
             {"clusters", h.clusters},
             {"cores_per_cluster", h.cores_per_cluster},
             {"freq_mhz", h.freq_mhz},
             {"line_bytes", h.line_bytes},
             {"l1d_kb", h.l1d_kb},
             {"l2_kb", h.l2_kb},
             {"l3_kb_per_cluster", h.l3_kb_per_cluster},
             {"date", h.date}}},
           {"runs", json::array()},
           {"costs_us", m.costs_us},
           {"wall_s", m.wall_s}};
  for (const KernelRun& r : m.runs) {
    json co = json::array();
    for (const auto& c : r.corunners)
      co.push_back({{"kernel", c.kernel}, {"working_set_kb", c.working_set_kb}});
    json run = {{"kernel", r.kernel}, {"working_set_kb", r.working_set_kb},
                {"corunners", co},    {"ns_per_line", r.ns_per_line},
                {"cv", r.cv},         {"samples", r.samples}};
    if (r.ci95_pct) run["ci95_pct"] = *r.ci95_pct;
    j["runs"].push_back(std::move(run));
  }
}

Measurements measurements_from_json(const json& j, const std::string& file,
                                    const std::string& base) {
  Measurements m;
  const std::string hp = base + "/host";
  const json& h = j.is_object() && j.contains("host") ? j.at("host") : json();
  if (!h.is_object()) throw InputError(file, hp, "missing or not an object");
  m.host.hostname = field<std::string>(h, "hostname", file, hp);
  m.host.cpu_model = field<std::string>(h, "cpu_model", file, hp);
  m.host.cpus = field<int>(h, "cpus", file, hp);
  m.host.clusters = field<int>(h, "clusters", file, hp);
  m.host.cores_per_cluster = field<int>(h, "cores_per_cluster", file, hp);
  m.host.freq_mhz = field<double>(h, "freq_mhz", file, hp);
  m.host.line_bytes = field<int>(h, "line_bytes", file, hp);
  m.host.l1d_kb = field<double>(h, "l1d_kb", file, hp);
  m.host.l2_kb = field<double>(h, "l2_kb", file, hp);
  m.host.l3_kb_per_cluster = field<double>(h, "l3_kb_per_cluster", file, hp);
  m.host.date = field<std::string>(h, "date", file, hp);

  const json runs = field<json>(j, "runs", file, base);
  if (!runs.is_array()) throw InputError(file, base + "/runs", "not an array");
  for (std::size_t i = 0; i < runs.size(); ++i) {
    const std::string rp = base + "/runs/" + std::to_string(i);
    const json& r = runs[i];
    KernelRun k;
    k.kernel = field<std::string>(r, "kernel", file, rp);
    k.working_set_kb = field<double>(r, "working_set_kb", file, rp);
    k.ns_per_line = field<double>(r, "ns_per_line", file, rp);
    k.cv = field<double>(r, "cv", file, rp);
    k.samples = field<int>(r, "samples", file, rp);
    if (r.contains("ci95_pct") && !r.at("ci95_pct").is_null())  // optional: older files lack it
      k.ci95_pct = field<double>(r, "ci95_pct", file, rp);
    const json co = field<json>(r, "corunners", file, rp);
    if (!co.is_array()) throw InputError(file, rp + "/corunners", "not an array");
    for (std::size_t c = 0; c < co.size(); ++c) {
      const std::string cp = rp + "/corunners/" + std::to_string(c);
      k.corunners.push_back({field<std::string>(co[c], "kernel", file, cp),
                             field<double>(co[c], "working_set_kb", file, cp)});
    }
    if (!(k.ns_per_line > 0.0)) throw InputError(file, rp + "/ns_per_line", "must be positive");
    m.runs.push_back(std::move(k));
  }
  m.costs_us = field<std::map<std::string, std::vector<double>>>(j, "costs_us", file, base);
  m.wall_s = field<double>(j, "wall_s", file, base);
  return m;
}

}  // namespace rosguard::calibration
