/*
 * emu/plugin/count.c: counts guest instructions executed between markers.
 *
 *   -plugin libcount.so,out=FILE,mark=NAME:START:STOP[,mark=...]
 *
 * START and STOP are the (hex) entry addresses of two marker functions of
 * the guest program (emu/target: emu_<name>_start / emu_<name>_stop, found
 * with nm). Every executed guest instruction adds one to a counter (an
 * inline TCG op, no call); the marker's first instruction is excluded.
 * When START's first instruction executes, the counter is snapshotted; when
 * STOP's first instruction executes, "NAME COUNT" is appended to FILE with
 * COUNT = instructions executed in between (the rest of the start marker,
 * the measured code, and the call of the stop marker: a constant overhead
 * that emu-host measures with an empty region, channel "cal").
 *
 * Optional per-address profile: prof=FILE:NAME[:FROM:TO] writes "ADDRESS
 * COUNT" for every instruction executed while mark NAME is open (between its
 * start and stop markers; with FROM:TO only in its samples FROM..TO-1,
 * counted from 0), counted per translated block as it starts (a block runs to
 * its end: the replay takes no exception inside a measured region). The stop
 * marker's block is included; emu/bench.sh attributes addresses to functions.
 *
 * The count is of instructions, not cycles. Instructions skipped by a Thumb
 * IT condition are counted (QEMU calls instruction hooks before the
 * condition check; the core also issues them).
 */
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "qemu_plugin_min.h"

EMU_PLUGIN_EXPORT int qemu_plugin_version = EMU_QEMU_PLUGIN_VERSION;

#define MAX_MARKS 16

struct mark {
    char name[32];
    uint64_t start, stop;
    uint64_t snapshot;
    int open;
    uint64_t samples;
};

static struct mark marks[MAX_MARKS];
static int n_marks;
static uint64_t executed;
static FILE *out;
static uint64_t unmatched;

/* Per-address profile (prof=FILE:NAME). Addresses below PROF_SPAN, one
 * counter per halfword (Thumb instructions are 2 or 4 bytes). */
#define PROF_SPAN (1u << 20)
static uint64_t *prof_count;
static struct mark *prof_mark;
static char prof_name[32];
static uint64_t prof_from, prof_to = UINT64_MAX;
static FILE *prof_out;

struct tb_addrs {
    size_t n;
    uint32_t va[];
};

static void on_tb_exec(unsigned int vcpu, void *ud)
{
    const struct tb_addrs *t = ud;
    (void)vcpu;
    if (!prof_mark || !prof_mark->open || prof_mark->samples < prof_from || prof_mark->samples >= prof_to) {
        return;
    }
    for (size_t i = 0; i < t->n; i++) {
        prof_count[t->va[i] >> 1]++;
    }
}

static void on_start(unsigned int vcpu, void *ud)
{
    struct mark *m = ud;
    (void)vcpu;
    m->snapshot = executed;
    m->open = 1;
}

static void on_stop(unsigned int vcpu, void *ud)
{
    struct mark *m = ud;
    (void)vcpu;
    if (!m->open) {
        unmatched++;
        return;
    }
    m->open = 0;
    m->samples++;
    fprintf(out, "%s %" PRIu64 "\n", m->name, executed - m->snapshot);
}

static void on_trans(qemu_plugin_id_t id, struct qemu_plugin_tb *tb)
{
    size_t n = qemu_plugin_tb_n_insns(tb);
    (void)id;
    if (prof_count && n > 0) {
        /* Blocks are translated once and live as long as the program here
         * (no self-modifying code), so the address list is never freed. */
        struct tb_addrs *t = malloc(sizeof *t + n * sizeof t->va[0]);
        size_t k = 0;
        for (size_t i = 0; t && i < n; i++) {
            uint64_t va = qemu_plugin_insn_vaddr(qemu_plugin_tb_get_insn(tb, i));
            if (va < PROF_SPAN) {
                t->va[k++] = (uint32_t)va;
            }
        }
        if (t) {
            t->n = k;
            qemu_plugin_register_vcpu_tb_exec_cb(tb, on_tb_exec, QEMU_PLUGIN_CB_NO_REGS, t);
        }
    }
    for (size_t i = 0; i < n; i++) {
        struct qemu_plugin_insn *insn = qemu_plugin_tb_get_insn(tb, i);
        uint64_t va = qemu_plugin_insn_vaddr(insn);
        int special = 0;
        for (int k = 0; k < n_marks; k++) {
            if (va == marks[k].start) {
                qemu_plugin_register_vcpu_insn_exec_cb(insn, on_start, QEMU_PLUGIN_CB_NO_REGS, &marks[k]);
                special = 1;
            } else if (va == marks[k].stop) {
                qemu_plugin_register_vcpu_insn_exec_cb(insn, on_stop, QEMU_PLUGIN_CB_NO_REGS, &marks[k]);
                special = 1;
            }
        }
        if (!special) {
            qemu_plugin_register_vcpu_insn_exec_inline(insn, QEMU_PLUGIN_INLINE_ADD_U64, &executed, 1);
        }
    }
}

static void on_exit_cb(qemu_plugin_id_t id, void *ud)
{
    char buf[256];
    (void)id;
    (void)ud;
    for (int k = 0; k < n_marks; k++) {
        snprintf(buf, sizeof buf, "count: %.31s %" PRIu64 " samples\n", marks[k].name, marks[k].samples);
        qemu_plugin_outs(buf);
    }
    snprintf(buf, sizeof buf, "count: %" PRIu64 " instructions counted in total, %" PRIu64 " unmatched stops\n",
             executed, unmatched);
    qemu_plugin_outs(buf);
    if (out) {
        fflush(out);
    }
    if (prof_out) {
        for (uint32_t i = 0; i < PROF_SPAN / 2; i++) {
            if (prof_count[i]) {
                fprintf(prof_out, "%08" PRIx32 " %" PRIu64 "\n", i << 1, prof_count[i]);
            }
        }
        fclose(prof_out);
    }
}

EMU_PLUGIN_EXPORT int qemu_plugin_install(qemu_plugin_id_t id, const qemu_info_t *info, int argc, char **argv)
{
    const char *path = NULL;
    if (info->version.min > EMU_QEMU_PLUGIN_VERSION) {
        fprintf(stderr, "count: QEMU needs plugin API >= %d, this is %d\n", info->version.min,
                EMU_QEMU_PLUGIN_VERSION);
        return -1;
    }
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        if (strncmp(a, "out=", 4) == 0) {
            path = a + 4;
        } else if (strncmp(a, "mark=", 5) == 0 && n_marks < MAX_MARKS) {
            struct mark *m = &marks[n_marks];
            char name[32];
            if (sscanf(a + 5, "%31[^:]:%" SCNx64 ":%" SCNx64, name, &m->start, &m->stop) != 3) {
                fprintf(stderr, "count: bad argument %s (mark=NAME:START:STOP)\n", a);
                return -1;
            }
            /* Thumb function symbols have bit 0 set; instructions do not. */
            m->start &= ~(uint64_t)1;
            m->stop &= ~(uint64_t)1;
            memcpy(m->name, name, sizeof name);
            n_marks++;
        } else if (strncmp(a, "prof=", 5) == 0) {
            /* FILE:NAME or FILE:NAME:FROM:TO (FILE has no colon). */
            const char *colon = strchr(a + 5, ':');
            if (!colon || sscanf(colon + 1, "%31[^:]:%" SCNu64 ":%" SCNu64, prof_name, &prof_from, &prof_to) < 1) {
                fprintf(stderr, "count: bad argument %s (prof=FILE:NAME[:FROM:TO])\n", a);
                return -1;
            }
            char *file = strndup(a + 5, (size_t)(colon - (a + 5)));
            prof_out = file ? fopen(file, "w") : NULL;
            if (!prof_out) {
                perror(file ? file : "prof");
                return -1;
            }
            free(file);
        } else {
            fprintf(stderr, "count: unknown argument %s\n", a);
            return -1;
        }
    }
    if (!path || n_marks == 0) {
        fprintf(stderr, "count: need out=FILE and at least one mark=NAME:START:STOP\n");
        return -1;
    }
    if (prof_out) {
        for (int k = 0; k < n_marks; k++) {
            if (strcmp(marks[k].name, prof_name) == 0) {
                prof_mark = &marks[k];
            }
        }
        prof_count = calloc(PROF_SPAN / 2, sizeof *prof_count);
        if (!prof_mark || !prof_count) {
            fprintf(stderr, "count: prof=...:%s names no mark (or no memory)\n", prof_name);
            return -1;
        }
    }
    out = fopen(path, "w");
    if (!out) {
        perror(path);
        return -1;
    }
    qemu_plugin_register_vcpu_tb_trans_cb(id, on_trans);
    qemu_plugin_register_atexit_cb(id, on_exit_cb, NULL);
    return 0;
}
