// SPDX-License-Identifier: MIT
/*
 * insn_count.c - QEMU TCG plugin: exact guest instruction count of code
 * regions delimited by two marker functions (imucal benchmarks).
 *
 * Every execution of the instruction at `begin` snapshots the running
 * instruction count; every execution of the instruction at `end` prints
 *     insn_count <N>
 * where N = instructions executed from the begin marker's first instruction
 * (inclusive) up to the end marker's first instruction (exclusive).
 * Regions are sequential (begin, end, begin, end, ...), not nested; an `end`
 * without a preceding `begin` is ignored.
 *
 * Written against the QEMU 7.2 plugin API (QEMU_PLUGIN_VERSION 1). QEMU's
 * Debian package ships no qemu-plugin.h, so the few declarations used are
 * repeated below. No glib needed.
 *
 * With profile=PATH, it also counts the instructions inside the regions by
 * address (an exec callback on every instruction: slower), only in the first
 * N regions with profile_regions=N, and writes "ADDR COUNT" lines to PATH at
 * exit, then "regions N" (the regions profiled): bench/insn_profile.py reads
 * them.
 *
 * Build:  cc -shared -fPIC -O2 -o libinsn_count.so insn_count.c
 * Run:    qemu-system-arm ... -plugin ./libinsn_count.so,begin=0xADDR,end=0xADDR \
 *             -d plugin -D plugin.log
 * (ADDR = symbol value from nm; the Thumb bit 0 is masked off here.)
 * bench/qemu_plugin/qemu_insn_count.sh wraps all of this.
 *
 * Exactness: every instruction gets an inline "counter += 1" op; only the two
 * marker instructions additionally get an exec callback. Whether QEMU runs a
 * callback before or after the inline op of the *same* instruction does not
 * matter, because both markers are instrumented identically and N is a
 * difference of two snapshots (QEMU 7.2 emits callbacks before inline ops,
 * so the snapshot excludes the marker instruction itself).
 * The profile agrees with N because its callback on a marker is registered
 * after the marker's own, and QEMU 7.2 runs callbacks in registration order:
 * the begin marker is counted, the end marker is not, as in N.
 * bench/insn_profile.py checks that the profile's total equals the regions'.
 */
#include <inttypes.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- subset of QEMU 7.2 include/qemu/qemu-plugin.h ---- */
#define QEMU_PLUGIN_EXPORT __attribute__((visibility("default")))
typedef uint64_t qemu_plugin_id_t;
typedef struct qemu_info_t {
  const char* target_name;
  struct {
    int min;
    int cur;
  } version;
  bool system_emulation;
  union {
    struct {
      int smp_vcpus;
      int max_vcpus;
    } system;
  };
} qemu_info_t;
struct qemu_plugin_tb;
struct qemu_plugin_insn;
enum qemu_plugin_cb_flags { QEMU_PLUGIN_CB_NO_REGS, QEMU_PLUGIN_CB_R_REGS, QEMU_PLUGIN_CB_RW_REGS };
enum qemu_plugin_op { QEMU_PLUGIN_INLINE_ADD_U64 };
typedef void (*qemu_plugin_udata_cb_t)(qemu_plugin_id_t id, void* userdata);
typedef void (*qemu_plugin_vcpu_udata_cb_t)(unsigned int vcpu_index, void* userdata);
typedef void (*qemu_plugin_vcpu_tb_trans_cb_t)(qemu_plugin_id_t id, struct qemu_plugin_tb* tb);
void qemu_plugin_register_vcpu_tb_trans_cb(qemu_plugin_id_t id, qemu_plugin_vcpu_tb_trans_cb_t cb);
void qemu_plugin_register_vcpu_insn_exec_cb(struct qemu_plugin_insn* insn,
                                            qemu_plugin_vcpu_udata_cb_t cb,
                                            enum qemu_plugin_cb_flags flags, void* userdata);
void qemu_plugin_register_vcpu_insn_exec_inline(struct qemu_plugin_insn* insn,
                                                enum qemu_plugin_op op, void* ptr, uint64_t imm);
size_t qemu_plugin_tb_n_insns(const struct qemu_plugin_tb* tb);
struct qemu_plugin_insn* qemu_plugin_tb_get_insn(const struct qemu_plugin_tb* tb, size_t idx);
uint64_t qemu_plugin_insn_vaddr(const struct qemu_plugin_insn* insn);
void qemu_plugin_outs(const char* string);
void qemu_plugin_register_atexit_cb(qemu_plugin_id_t id, qemu_plugin_udata_cb_t cb, void* userdata);
QEMU_PLUGIN_EXPORT int qemu_plugin_version = 1; /* QEMU_PLUGIN_VERSION */
/* ---- end of API subset ---- */

static uint64_t begin_addr, end_addr;
static uint64_t insn_count; /* running count, bumped inline (single vCPU) */
static uint64_t snapshot;   /* insn_count at the latest begin marker */
static bool in_region;
static uint64_t regions; /* regions ended */

/* Profile mode: one counter per instruction address, in blocks that never move (QEMU keeps
 * the counter's address in the translated code). */
#define PROFILE_BLOCK 4096
struct profile_block {
  uint64_t pc[PROFILE_BLOCK];
  uint64_t count[PROFILE_BLOCK];
  size_t used;
  struct profile_block* next;
};
static const char* profile_path;
static uint64_t profile_regions; /* 0: all */
static bool profiling;           /* inside a region that is profiled */
static struct profile_block* profile_head;

static uint64_t* profile_counter(uint64_t pc) {
  struct profile_block* b;
  for (b = profile_head; b; b = b->next)
    for (size_t i = 0; i < b->used; i++)
      if (b->pc[i] == pc) return &b->count[i];
  if (!profile_head || profile_head->used == PROFILE_BLOCK) {
    b = calloc(1, sizeof *b);
    if (!b) {
      fprintf(stderr, "insn_count: out of memory, the profile misses instructions\n");
      return NULL;
    }
    b->next = profile_head;
    profile_head = b;
  }
  b = profile_head;
  b->pc[b->used] = pc;
  return &b->count[b->used++];
}

static void on_profiled(unsigned int vcpu, void* counter) {
  (void)vcpu;
  if (profiling) ++*(uint64_t*)counter;
}

static void on_exit_write_profile(qemu_plugin_id_t id, void* udata) {
  FILE* f = fopen(profile_path, "w");
  (void)id;
  (void)udata;
  if (!f) {
    fprintf(stderr, "insn_count: cannot write %s\n", profile_path);
    return;
  }
  for (struct profile_block* b = profile_head; b; b = b->next)
    for (size_t i = 0; i < b->used; i++)
      if (b->count[i]) fprintf(f, "%" PRIx64 " %" PRIu64 "\n", b->pc[i], b->count[i]);
  fprintf(f, "regions %" PRIu64 "\n",
          profile_regions && profile_regions < regions ? profile_regions : regions);
  fclose(f);
}

static void on_begin(unsigned int vcpu, void* udata) {
  (void)vcpu;
  (void)udata;
  snapshot = insn_count;
  in_region = true;
  profiling = profile_path && (profile_regions == 0 || regions < profile_regions);
}

static void on_end(unsigned int vcpu, void* udata) {
  char line[48];
  (void)vcpu;
  (void)udata;
  if (!in_region) return;
  in_region = profiling = false;
  ++regions;
  snprintf(line, sizeof line, "insn_count %" PRIu64 "\n", insn_count - snapshot);
  qemu_plugin_outs(line);
}

static void on_tb_trans(qemu_plugin_id_t id, struct qemu_plugin_tb* tb) {
  size_t n = qemu_plugin_tb_n_insns(tb);
  (void)id;
  for (size_t i = 0; i < n; i++) {
    struct qemu_plugin_insn* insn = qemu_plugin_tb_get_insn(tb, i);
    uint64_t pc = qemu_plugin_insn_vaddr(insn);
    /* Same registration order for both markers => same cb/inline order. */
    if (pc == begin_addr)
      qemu_plugin_register_vcpu_insn_exec_cb(insn, on_begin, QEMU_PLUGIN_CB_NO_REGS, NULL);
    else if (pc == end_addr)
      qemu_plugin_register_vcpu_insn_exec_cb(insn, on_end, QEMU_PLUGIN_CB_NO_REGS, NULL);
    qemu_plugin_register_vcpu_insn_exec_inline(insn, QEMU_PLUGIN_INLINE_ADD_U64, &insn_count, 1);
    if (profile_path) {
      uint64_t* counter = profile_counter(pc);
      if (counter)
        qemu_plugin_register_vcpu_insn_exec_cb(insn, on_profiled, QEMU_PLUGIN_CB_NO_REGS, counter);
    }
  }
}

QEMU_PLUGIN_EXPORT int qemu_plugin_install(qemu_plugin_id_t id, const qemu_info_t* info, int argc,
                                           char** argv) {
  (void)info;
  for (int i = 0; i < argc; i++) {
    if (strncmp(argv[i], "begin=", 6) == 0)
      begin_addr = strtoull(argv[i] + 6, NULL, 0) & ~1ULL;
    else if (strncmp(argv[i], "end=", 4) == 0)
      end_addr = strtoull(argv[i] + 4, NULL, 0) & ~1ULL;
    else if (strncmp(argv[i], "profile=", 8) == 0)
      profile_path = argv[i] + 8;
    else if (strncmp(argv[i], "profile_regions=", 16) == 0)
      profile_regions = strtoull(argv[i] + 16, NULL, 0);
    else {
      fprintf(stderr, "insn_count: unknown argument '%s'\n", argv[i]);
      return -1;
    }
  }
  if (!begin_addr || !end_addr || begin_addr == end_addr) {
    fprintf(stderr, "insn_count: need distinct non-zero begin=0xADDR,end=0xADDR\n");
    return -1;
  }
  qemu_plugin_register_vcpu_tb_trans_cb(id, on_tb_trans);
  if (profile_path) qemu_plugin_register_atexit_cb(id, on_exit_write_profile, NULL);
  return 0;
}
