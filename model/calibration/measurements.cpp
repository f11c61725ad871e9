#include "calibration/measurements.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

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
             {"date", h.date},
             {"kernel", h.kernel}}},
           {"runs", json::array()},
           {"costs_us", m.costs_us},
           {"wall_s", m.wall_s},
           {"contention", json::array()}};
  for (const ContentionProbe& p : m.contention)
    j["contention"].push_back(probe_to_json(p));
  for (const KernelRun& r : m.runs) {
    json co = json::array();
    for (const auto& c : r.corunners)
      co.push_back({{"kernel", c.kernel}, {"working_set_kb", c.working_set_kb}});
    json run = {{"kernel", r.kernel}, {"working_set_kb", r.working_set_kb},
                {"corunners", co},    {"ns_per_line", r.ns_per_line},
                {"cv", r.cv},         {"samples", r.samples}};
    if (r.ci95_pct) run["ci95_pct"] = *r.ci95_pct;
    if (!r.probes.empty()) run["probes"] = r.probes;
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
  // Measurements made before rosguard recorded the kernel have none.
  if (h.contains("kernel")) m.host.kernel = field<std::string>(h, "kernel", file, hp);

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
    if (r.contains("probes"))  // optional: isolation runs and older files have none
      k.probes = field<std::vector<int>>(r, "probes", file, rp);
    m.runs.push_back(std::move(k));
  }
  m.costs_us = field<std::map<std::string, std::vector<double>>>(j, "costs_us", file, base);
  m.wall_s = field<double>(j, "wall_s", file, base);
  if (j.contains("contention")) {  // optional: older files lack it
    const json probes = field<json>(j, "contention", file, base);
    if (!probes.is_array()) throw InputError(file, base + "/contention", "not an array");
    for (std::size_t i = 0; i < probes.size(); ++i)
      m.contention.push_back(
          probe_from_json(probes[i], file, base + "/contention/" + std::to_string(i)));
  }
  for (std::size_t i = 0; i < m.runs.size(); ++i)
    for (std::size_t p = 0; p < m.runs[i].probes.size(); ++p)
      if (const int at = m.runs[i].probes[p];
          at < 0 || static_cast<std::size_t>(at) >= m.contention.size())
        throw InputError(file, base + "/runs/" + std::to_string(i) + "/probes/" + std::to_string(p),
                         "no probe " + std::to_string(at) + " in /contention (" +
                             std::to_string(m.contention.size()) + " probes)");
  return m;
}

MachineIdentity machine_identity(const HostFacts& host) {
  MachineIdentity id;
  id.cpu_model = host.cpu_model;
  id.cpus = host.cpus;
  id.l1d_kb = host.l1d_kb;
  id.l2_kb = host.l2_kb;
  id.l3_kb_per_cluster = host.l3_kb_per_cluster;
  id.kernel = host.kernel;
  id.hostname = host.hostname;
  id.date = host.date;
  return id;
}

namespace {

std::string kb(double v) {
  if (!(v > 0.0)) return "not reported";
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.6g KB", v);
  return buf;
}

bool same_size(double a, double b) {
  if (a == b) return true;
  return std::fabs(a - b) <= 0.01 * std::max(std::fabs(a), std::fabs(b));
}

}  // namespace

std::vector<std::string> identity_differences(const MachineIdentity& model,
                                              const MachineIdentity& current) {
  std::vector<std::string> out;
  const auto differ = [&](const std::string& what, const std::string& a, const std::string& b) {
    out.push_back(what + " " + a + " (model) vs " + b + " (this machine)");
  };
  if (model.cpu_model != current.cpu_model)
    differ("CPU model", "'" + model.cpu_model + "'", "'" + current.cpu_model + "'");
  if (model.cpus != current.cpus)
    differ("usable CPUs", std::to_string(model.cpus), std::to_string(current.cpus));
  if (!same_size(model.l1d_kb, current.l1d_kb)) differ("L1d", kb(model.l1d_kb), kb(current.l1d_kb));
  if (!same_size(model.l2_kb, current.l2_kb)) differ("L2", kb(model.l2_kb), kb(current.l2_kb));
  if (!same_size(model.l3_kb_per_cluster, current.l3_kb_per_cluster))
    differ("L3 per cluster", kb(model.l3_kb_per_cluster), kb(current.l3_kb_per_cluster));
  if (model.kernel.empty())
    out.push_back("kernel not recorded by the model (this machine: " +
                  (current.kernel.empty() ? std::string("unknown") : current.kernel) + ")");
  else if (model.kernel != current.kernel)
    differ("kernel", model.kernel, current.kernel);
  return out;
}

std::string describe(const MachineIdentity& id) {
  const auto size = [](double v) { return v > 0.0 ? kb(v) : std::string("?"); };
  return (id.cpu_model.empty() ? std::string("unknown CPU") : id.cpu_model) + ", " +
         std::to_string(id.cpus) + " CPUs, L1d " + size(id.l1d_kb) + ", L2 " + size(id.l2_kb) +
         ", L3 " + size(id.l3_kb_per_cluster) + ", " +
         (id.kernel.empty() ? std::string("kernel not recorded") : id.kernel);
}

json identity_to_json(const MachineIdentity& id) {
  json j{{"cpu_model", id.cpu_model},
         {"cpus", id.cpus},
         {"l1d_kb", id.l1d_kb},
         {"l2_kb", id.l2_kb},
         {"l3_kb_per_cluster", id.l3_kb_per_cluster}};
  if (!id.kernel.empty()) j["kernel"] = id.kernel;
  if (!id.hostname.empty()) j["hostname"] = id.hostname;
  if (!id.date.empty()) j["date"] = id.date;
  if (id.dram_contention) j["dram_contention"] = probe_to_json(*id.dram_contention);
  return j;
}

MachineIdentity identity_from_json(const json& j, const std::string& file,
                                   const std::string& base) {
  if (!j.is_object()) throw InputError(file, base, "not an object");
  MachineIdentity id;
  id.cpu_model = field<std::string>(j, "cpu_model", file, base);
  id.cpus = field<int>(j, "cpus", file, base);
  id.l1d_kb = field<double>(j, "l1d_kb", file, base);
  id.l2_kb = field<double>(j, "l2_kb", file, base);
  id.l3_kb_per_cluster = field<double>(j, "l3_kb_per_cluster", file, base);
  if (j.contains("kernel")) id.kernel = field<std::string>(j, "kernel", file, base);
  if (j.contains("hostname")) id.hostname = field<std::string>(j, "hostname", file, base);
  if (j.contains("date")) id.date = field<std::string>(j, "date", file, base);
  if (j.contains("dram_contention"))
    id.dram_contention = probe_from_json(j.at("dram_contention"), file, base + "/dram_contention");
  return id;
}

bool same_contention_state(const ContentionProbe& a, const ContentionProbe& b) {
  return std::fabs(std::log(a.ratio / b.ratio)) <= std::log1p(kContentionTolerance);
}

std::optional<double> speed_offset_pct(const ContentionProbe& model, const ContentionProbe& now) {
  if (!model.alone_ns_per_line || !now.alone_ns_per_line) return std::nullopt;
  return 100.0 * (*now.alone_ns_per_line / *model.alone_ns_per_line - 1.0);
}

std::optional<ContentionProbe> contention_state(const std::vector<ContentionProbe>& probes,
                                                const ContentionProbe* around) {
  if (probes.empty()) return std::nullopt;
  const auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
  };
  const auto agreeing = [&](const ContentionProbe& anchor) {
    return std::count_if(probes.begin(), probes.end(), [&](const ContentionProbe& p) {
      return same_contention_state(anchor, p);
    });
  };
  const ContentionProbe* anchor = around ? around : &probes.front();
  if (!around)
    for (const ContentionProbe& p : probes)
      if (agreeing(p) > agreeing(*anchor)) anchor = &p;
  ContentionProbe state = *anchor;
  std::vector<double> ratios, cis, alone;
  state.rounds = 0;
  for (const ContentionProbe& p : probes) {
    if (!same_contention_state(*anchor, p)) continue;
    ratios.push_back(p.ratio);
    state.rounds += p.rounds;
    if (p.ci95_pct) cis.push_back(*p.ci95_pct);
    if (p.alone_ns_per_line) alone.push_back(*p.alone_ns_per_line);
  }
  const std::size_t n = ratios.size();
  state.ratio = median(ratios);
  state.ci95_pct = cis.empty() ? std::nullopt : std::optional<double>(median(cis));
  state.alone_ns_per_line = alone.empty() ? std::nullopt : std::optional<double>(median(alone));
  state.when = std::to_string(n) + " of " + std::to_string(probes.size()) +
               " probes of the suite in this state";
  return state;
}

std::optional<ContentionProbe> suite_state(const Measurements& m) {
  // Per probe, the co-runs whose every probe agrees with it.
  const auto runs_in = [&](const ContentionProbe& anchor) {
    return std::count_if(m.runs.begin(), m.runs.end(), [&](const KernelRun& r) {
      return !r.probes.empty() && std::all_of(r.probes.begin(), r.probes.end(), [&](int at) {
        return same_contention_state(anchor, m.contention[static_cast<std::size_t>(at)]);
      });
    });
  };
  const ContentionProbe* best = nullptr;
  long most = 0;
  for (const ContentionProbe& p : m.contention)
    if (const long n = runs_in(p); n > most) {
      best = &p;
      most = n;
    }
  if (!best) return contention_state(m.contention);
  auto state = contention_state(m.contention, best);
  state->when += " (" + std::to_string(most) + " co-runs)";
  return state;
}

std::string describe(const ContentionProbe& p) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "%.2fx", p.ratio);
  std::string s = buf;
  if (p.ci95_pct) {
    std::snprintf(buf, sizeof buf, " +- %.1f %%", *p.ci95_pct);
    s += buf;
  }
  s += " (bandwidth_read " + kb(p.working_set_kb);
  if (p.cores.size() == 2)
    s += " on CPU " + std::to_string(p.cores[0]) + " beside CPU " + std::to_string(p.cores[1]);
  if (p.alone_ns_per_line) {
    std::snprintf(buf, sizeof buf, "; alone %.2f ns per line", *p.alone_ns_per_line);
    s += buf;
  }
  return s + ")";
}

json probe_to_json(const ContentionProbe& p) {
  json j{{"cores", p.cores},   {"working_set_kb", p.working_set_kb},
         {"ratio", p.ratio},   {"ci95_pct", p.ci95_pct ? json(*p.ci95_pct) : json(nullptr)},
         {"rounds", p.rounds}, {"date", p.date}};
  if (!p.when.empty()) j["when"] = p.when;
  if (p.alone_ns_per_line) j["alone_ns_per_line"] = *p.alone_ns_per_line;
  return j;
}

ContentionProbe probe_from_json(const json& j, const std::string& file, const std::string& base) {
  if (!j.is_object()) throw InputError(file, base, "not an object");
  ContentionProbe p;
  p.cores = field<std::vector<int>>(j, "cores", file, base);
  if (p.cores.size() != 2) throw InputError(file, base + "/cores", "must name two CPUs");
  p.working_set_kb = field<double>(j, "working_set_kb", file, base);
  p.ratio = field<double>(j, "ratio", file, base);
  if (!(p.ratio > 0.0)) throw InputError(file, base + "/ratio", "must be positive");
  if (j.contains("ci95_pct") && !j.at("ci95_pct").is_null())
    p.ci95_pct = field<double>(j, "ci95_pct", file, base);
  p.rounds = field<int>(j, "rounds", file, base);
  p.date = field<std::string>(j, "date", file, base);
  if (j.contains("when")) p.when = field<std::string>(j, "when", file, base);
  if (j.contains("alone_ns_per_line")) {
    p.alone_ns_per_line = field<double>(j, "alone_ns_per_line", file, base);
    if (!(*p.alone_ns_per_line > 0.0))
      throw InputError(file, base + "/alone_ns_per_line", "must be positive");
  }
  return p;
}

}  // namespace rosguard::calibration
