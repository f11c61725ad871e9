/* rosguard-rt-node: a stand-alone RT node in a process of its own, for rosguard's DDS transport.
 *
 * It plays the critical node of a scenario whose RT node says "signal": "topic": it publishes
 * std_msgs/msg/Bool on the ROS 2 topic <ns>/rosguard/<name>/active (DDS topic
 * rt<ns>/rosguard/<name>/active, type std_msgs::msg::dds_::Bool_, reliable, keep last 10,
 * volatile), true right before each job and false right after it, and runs each job: a
 * sequential read of a working set, one access per 64-byte line (IsolBench-style
 * bandwidth_read), for --job-ms milliseconds. Plain C on Cyclone DDS's C API; no ROS needed.
 *
 * It waits (at most --wait-ms) for a subscriber to match before the first job: the topic is
 * volatile, so a signal sent before the controller listens would be lost. It prints one line per
 * job with CLOCK_MONOTONIC stamps. Exit status: 0 done, 2 bad usage, 3 no subscriber in time,
 * 1 DDS error.
 *
 *   rosguard-rt-node --name rt0 [--ns /lab1] [--domain N] [--jobs 3] [--job-ms 200]
 *                    [--gap-ms 100] [--working-set-kb 65536] [--core N] [--wait-ms 30000]
 *                    [--start-delay-ms 0]
 */
#define _GNU_SOURCE
#include <errno.h>
#include <inttypes.h>
#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "Bool.h"
#include "dds/dds.h"

static int64_t mono_ns(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
}

static void sleep_ms(long ms) {
  struct timespec ts = {ms / 1000, (ms % 1000) * 1000000L};
  while (nanosleep(&ts, &ts) != 0 && errno == EINTR) {
  }
}

static int usage(const char* why) {
  fprintf(stderr,
          "rosguard-rt-node: %s\n"
          "usage: rosguard-rt-node --name NODE [--ns /NAMESPACE] [--domain N] [--jobs N]\n"
          "       [--job-ms MS] [--gap-ms MS] [--working-set-kb KB] [--core CPU]\n"
          "       [--wait-ms MS] [--start-delay-ms MS]\n",
          why);
  return 2;
}

static int parse_long(const char* s, long min, long max, long* out) {
  char* end = NULL;
  errno = 0;
  const long v = strtol(s, &end, 10);
  if (errno != 0 || end == s || *end != '\0' || v < min || v > max) return 0;
  *out = v;
  return 1;
}

/* One job: read the working set line by line until `ms` have passed. Returns the lines read. */
static uint64_t run_job(const volatile uint64_t* buf, size_t words, long ms) {
  const int64_t until = mono_ns() + (int64_t)ms * 1000000;
  uint64_t lines = 0, sink = 0;
  do {
    for (size_t i = 0; i < words; i += 8) /* 8 words = one 64-byte line */
      sink += buf[i];
    lines += words / 8;
  } while (mono_ns() < until);
  if (sink == 42) fputs("", stderr); /* keeps the reads */
  return lines;
}

int main(int argc, char** argv) {
  const char* name = NULL;
  const char* ns = "";
  long domain = -1, jobs = 3, job_ms = 200, gap_ms = 100, ws_kb = 65536, core = -1;
  long wait_ms = 30000, start_delay_ms = 0;
  for (int i = 1; i < argc; ++i) {
    const char* a = argv[i];
    const char* v = i + 1 < argc ? argv[i + 1] : NULL;
    int ok = 1;
    if (!v) return usage("every option takes a value");
    if (strcmp(a, "--name") == 0) name = v;
    else if (strcmp(a, "--ns") == 0) ns = v;
    else if (strcmp(a, "--domain") == 0) ok = parse_long(v, 0, 232, &domain);
    else if (strcmp(a, "--jobs") == 0) ok = parse_long(v, 1, 1000000, &jobs);
    else if (strcmp(a, "--job-ms") == 0) ok = parse_long(v, 1, 3600000, &job_ms);
    else if (strcmp(a, "--gap-ms") == 0) ok = parse_long(v, 0, 3600000, &gap_ms);
    else if (strcmp(a, "--working-set-kb") == 0) ok = parse_long(v, 4, 16777216, &ws_kb);
    else if (strcmp(a, "--core") == 0) ok = parse_long(v, 0, 1023, &core);
    else if (strcmp(a, "--wait-ms") == 0) ok = parse_long(v, 0, 3600000, &wait_ms);
    else if (strcmp(a, "--start-delay-ms") == 0) ok = parse_long(v, 0, 3600000, &start_delay_ms);
    else return usage("unknown option");
    if (!ok) return usage("a value is out of range");
    ++i;
  }
  if (!name || !*name) return usage("--name is required");
  if (*ns && ns[0] != '/') return usage("--ns must start with '/'");

  if (core >= 0) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET((int)core, &set);
    if (sched_setaffinity(0, sizeof set, &set) != 0) {
      fprintf(stderr, "rosguard-rt-node: cannot pin to CPU %ld: %s\n", core, strerror(errno));
      return 1;
    }
  }
  const size_t words = (size_t)ws_kb * 1024 / sizeof(uint64_t);
  uint64_t* buf = malloc(words * sizeof(uint64_t));
  if (!buf) return 1;
  for (size_t i = 0; i < words; ++i) buf[i] = i; /* touch every page before the first job */

  /* The ROS 2 name /<ns>/rosguard/<name>/active is the DDS topic rt<ns>/rosguard/<name>/active. */
  char topic_name[512];
  snprintf(topic_name, sizeof topic_name, "rt%s/rosguard/%s/active", ns, name);

  /* Domain: --domain, else ROS_DOMAIN_ID, else 0 (as ROS 2 and rosguard pick it). */
  if (domain < 0) {
    const char* env = getenv("ROS_DOMAIN_ID");
    domain = 0;
    if (env && *env && !parse_long(env, 0, 232, &domain)) return usage("bad ROS_DOMAIN_ID");
  }
  const dds_entity_t participant = dds_create_participant((dds_domainid_t)domain, NULL, NULL);
  if (participant < 0) {
    fprintf(stderr, "rosguard-rt-node: dds_create_participant: %s\n",
            dds_strretcode(participant));
    return 1;
  }
  const dds_entity_t topic =
      dds_create_topic(participant, &std_msgs_msg_dds__Bool__desc, topic_name, NULL, NULL);
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 10);
  dds_qset_durability(qos, DDS_DURABILITY_VOLATILE);
  const dds_entity_t writer = topic < 0 ? topic : dds_create_writer(participant, topic, qos, NULL);
  dds_delete_qos(qos);
  if (writer < 0) {
    fprintf(stderr, "rosguard-rt-node: creating the writer of %s: %s\n", topic_name,
            dds_strretcode(writer));
    dds_delete(participant);
    return 1;
  }

  /* Wait for the controller's reader. */
  const int64_t give_up = mono_ns() + (int64_t)wait_ms * 1000000;
  dds_publication_matched_status_t st;
  while (dds_get_publication_matched_status(writer, &st) == 0 && st.current_count == 0) {
    if (mono_ns() >= give_up) {
      fprintf(stderr, "rosguard-rt-node: no subscriber on %s (domain %ld) within %ld ms\n",
              topic_name, domain, wait_ms);
      dds_delete(participant);
      return 3;
    }
    sleep_ms(5); /* waiting for discovery, not for data: a coarse poll is fine here */
  }
  printf("rt-node %s: subscriber matched on %s (domain %ld)\n", name, topic_name, domain);
  fflush(stdout);
  if (start_delay_ms > 0) sleep_ms(start_delay_ms);

  int rc = 0;
  for (long j = 0; j < jobs && rc == 0; ++j) {
    std_msgs_msg_dds__Bool_ msg = {true};
    const int64_t t0 = mono_ns();
    dds_return_t w = dds_write(writer, &msg);
    const uint64_t lines = w < 0 ? 0 : run_job(buf, words, job_ms);
    const int64_t t1 = mono_ns();
    msg.data = false;
    if (w >= 0) w = dds_write(writer, &msg);
    if (w < 0) {
      fprintf(stderr, "rosguard-rt-node: dds_write: %s\n", dds_strretcode(w));
      rc = 1;
      break;
    }
    printf("rt-node %s: job %ld active %" PRId64 " -> %" PRId64 " ns (%.3f ms, %" PRIu64
           " lines, %.0f MB/s)\n",
           name, j, t0, t1, (double)(t1 - t0) / 1e6, lines,
           (double)lines * 64.0 / (1024.0 * 1024.0) / ((double)(t1 - t0) / 1e9));
    fflush(stdout);
    if (j + 1 < jobs && gap_ms > 0) sleep_ms(gap_ms);
  }
  /* Reliable: make sure the last signal reached every matched reader before leaving. */
  if (rc == 0) dds_wait_for_acks(writer, DDS_SECS(5));
  dds_delete(participant);
  free(buf);
  return rc;
}
