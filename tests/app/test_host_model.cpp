// A host model knows its machine (issue 22): check_model_machine compares the model's
// "measured_on" with a given current machine (pure, no OS calls), and this_machine() reads the
// current one.
#include <catch2/catch.hpp>

#include "calibration/measurements.h"
#include "core/error.h"
#include "load/host_facts.h"
#include "load/host_model.h"

using namespace rosguard;
using json = nlohmann::json;

namespace {

calibration::MachineIdentity epyc() {
  calibration::MachineIdentity id;
  id.cpu_model = "AMD EPYC";
  id.cpus = 2;
  id.l1d_kb = 48;
  id.l2_kb = 1024;
  id.l3_kb_per_cluster = 32768;
  id.kernel = "Linux 6.18.44-fc-v669";
  id.hostname = "vm";
  id.date = "2026-11-23T16:39:42Z";
  return id;
}

// The development VM of 2026-11-26 (../shared/measured/dev-vm-2026-11-26/lscpu.txt).
calibration::MachineIdentity xeon() {
  calibration::MachineIdentity id;
  id.cpu_model = "Intel(R) Xeon(R) Processor @ 2.50GHz";
  id.cpus = 2;
  id.l1d_kb = 32;
  id.l2_kb = 1024;
  id.l3_kb_per_cluster = 36608;
  id.kernel = "Linux 6.18.44-fc-v782";
  id.hostname = "vm";
  id.date = "2026-11-26T10:00:00Z";
  return id;
}

json model_of(const calibration::MachineIdentity& id) {
  return json{{"name", "host"}, {"measured_on", calibration::identity_to_json(id)}};
}

bool has(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

}  // namespace

TEST_CASE("a host model of the current machine yields no warning", "[app][host]") {
  const ModelMachineCheck c = check_model_machine(model_of(epyc()), "model.json", epyc());
  CHECK(c.known);
  CHECK(c.matches);
  CHECK(c.differences.empty());
  CHECK(c.warning.empty());
  CHECK(c.record.at("matches") == true);
  CHECK(c.record.at("measured_on").at("cpu_model") == "AMD EPYC");
  CHECK(c.record.at("differences").empty());

  // The hostname and the date are not the machine: a renamed VM, a later day.
  calibration::MachineIdentity later = epyc();
  later.hostname = "vm-renamed";
  later.date = "2026-12-01T00:00:00Z";
  CHECK(check_model_machine(model_of(epyc()), "model.json", later).warning.empty());
}

TEST_CASE("a host model of another machine yields a warning listing each difference",
          "[app][host]") {
  const ModelMachineCheck c = check_model_machine(model_of(epyc()), "model.json", xeon());
  CHECK(c.known);
  CHECK_FALSE(c.matches);
  REQUIRE(c.differences.size() == 4);  // CPU model, L1d, L3, kernel; CPUs and L2 agree
  INFO(c.warning);
  CHECK(has(c.warning,
            "the host model model.json was measured on another machine "
            "(vm, 2026-11-23T16:39:42Z)"));
  CHECK(has(c.warning,
            "CPU model 'AMD EPYC' (model) vs 'Intel(R) Xeon(R) Processor @ 2.50GHz' (this "
            "machine)"));
  CHECK(has(c.warning, "L1d 48 KB (model) vs 32 KB (this machine)"));
  CHECK(has(c.warning, "L3 per cluster 32768 KB (model) vs 36608 KB (this machine)"));
  CHECK(has(c.warning, "kernel Linux 6.18.44-fc-v669 (model) vs Linux 6.18.44-fc-v782"));
  CHECK_FALSE(has(c.warning, "usable CPUs"));
  CHECK_FALSE(has(c.warning, "L2 "));
  CHECK(has(c.warning, "rosguard calibrate --install"));
  CHECK(c.record.at("matches") == false);
  CHECK(c.record.at("differences").size() == 4);
  CHECK(c.record.at("this_machine").at("cpu_model") == "Intel(R) Xeon(R) Processor @ 2.50GHz");

  // One fact is enough: the same CPU with fewer usable CPUs (a cpuset, taskset).
  calibration::MachineIdentity fewer = epyc();
  fewer.cpus = 1;
  const ModelMachineCheck one = check_model_machine(model_of(epyc()), "model.json", fewer);
  REQUIRE(one.differences.size() == 1);
  CHECK(has(one.warning, "usable CPUs 2 (model) vs 1 (this machine)"));
}

TEST_CASE("a host model that does not record its machine warns that it is unknown", "[app][host]") {
  const ModelMachineCheck c = check_model_machine(json{{"name", "host"}}, "old.json", epyc());
  CHECK_FALSE(c.known);
  CHECK_FALSE(c.matches);
  INFO(c.warning);
  CHECK(has(c.warning, "the host model old.json does not record the machine it was measured on"));
  CHECK(has(c.warning, "is unknown"));
  CHECK(c.record.at("measured_on").is_null());
  CHECK(c.record.at("matches").is_null());

  // A model refitted from measurements that predate the kernel's recording: not shown to match.
  calibration::MachineIdentity no_kernel = epyc();
  no_kernel.kernel.clear();
  const ModelMachineCheck partial = check_model_machine(model_of(no_kernel), "m.json", epyc());
  CHECK_FALSE(partial.matches);
  CHECK(has(partial.warning, "kernel not recorded by the model"));
}

TEST_CASE("a malformed measured_on is the model file's input error", "[app][host]") {
  json doc = model_of(epyc());
  doc["measured_on"].erase("cpus");
  CHECK_THROWS_AS(check_model_machine(doc, "model.json", epyc()), InputError);
}

TEST_CASE("this machine: a CPU model, usable CPUs and a kernel are read", "[app][host]") {
  const calibration::MachineIdentity me = this_machine();
  CHECK_FALSE(me.cpu_model.empty());
  CHECK(me.cpus >= 1);
  CHECK(me.kernel.rfind("Linux ", 0) == 0);
  CHECK(me.l1d_kb >= 0.0);
  // Read twice, the same machine.
  CHECK(calibration::identity_differences(me, this_machine()).empty());
}
