/*
 * Counts the guest instructions executed between two marker functions, for the firmware
 * example's per-frame budget (scripts/firmware). Arguments: begin=ADDR,end=ADDR (hex, the
 * markers' symbol addresses; the Thumb bit is ignored), out=FILE. Writes one line per
 * begin..end span: the instructions from entering `begin` to entering `end`. With
 * profile=FILE also writes, at exit, each address executed in the 4 MiB code region at 0 (the
 * board's flash) and how often: where the instructions went (scripts/firmware-profile.py maps
 * the addresses to the source files).
 *
 * Single vCPU (a Cortex-M): the counter is a plain global.
 */
#include "qemu-plugin-api.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

QEMU_PLUGIN_EXPORT int qemu_plugin_version = QEMU_PLUGIN_VERSION;

static uint64_t executed;    /* every instruction, inline-counted */
static uint64_t at_begin;    /* `executed` on entering the begin marker */
static uint64_t begin_addr, end_addr;
static FILE *out;
/* Executions of each halfword address of the code region (Thumb instructions are 2-aligned). */
#define CODE_BYTES (4u << 20)
static uint64_t *profile;
static const char *profile_path;

static void on_begin(unsigned int vcpu, void *udata)
{
    (void)vcpu;
    (void)udata;
    at_begin = executed;
}

static void on_end(unsigned int vcpu, void *udata)
{
    (void)vcpu;
    (void)udata;
    fprintf(out, "%llu\n", (unsigned long long)(executed - at_begin));
}

static void on_translate(qemu_plugin_id_t id, struct qemu_plugin_tb *tb)
{
    (void)id;
    size_t n = qemu_plugin_tb_n_insns(tb);
    for (size_t i = 0; i < n; i++) {
        struct qemu_plugin_insn *insn = qemu_plugin_tb_get_insn(tb, i);
        uint64_t pc = qemu_plugin_insn_vaddr(insn);
        /* The marker callbacks run before the instruction is counted. */
        if (pc == begin_addr) {
            qemu_plugin_register_vcpu_insn_exec_cb(insn, on_begin, QEMU_PLUGIN_CB_NO_REGS, NULL);
        } else if (pc == end_addr) {
            qemu_plugin_register_vcpu_insn_exec_cb(insn, on_end, QEMU_PLUGIN_CB_NO_REGS, NULL);
        }
        qemu_plugin_register_vcpu_insn_exec_inline(insn, QEMU_PLUGIN_INLINE_ADD_U64, &executed, 1);
        if (profile != NULL && pc < CODE_BYTES) {
            qemu_plugin_register_vcpu_insn_exec_inline(insn, QEMU_PLUGIN_INLINE_ADD_U64,
                                                       &profile[pc / 2], 1);
        }
    }
}

static void on_qemu_exit(qemu_plugin_id_t id, void *udata)
{
    (void)id;
    (void)udata;
    fclose(out);
    if (profile != NULL) {
        FILE *p = fopen(profile_path, "w");
        if (p == NULL) {
            perror(profile_path);
            return;
        }
        for (size_t i = 0; i < CODE_BYTES / 2; i++) {
            if (profile[i] != 0) {
                fprintf(p, "%zx %llu\n", 2 * i, (unsigned long long)profile[i]);
            }
        }
        fclose(p);
    }
}

QEMU_PLUGIN_EXPORT int qemu_plugin_install(qemu_plugin_id_t id, const qemu_info_t *info, int argc,
                                           char **argv)
{
    (void)info;
    const char *path = NULL;
    for (int i = 0; i < argc; i++) {
        if (strncmp(argv[i], "begin=", 6) == 0) {
            begin_addr = strtoull(argv[i] + 6, NULL, 16) & ~1ULL;
        } else if (strncmp(argv[i], "end=", 4) == 0) {
            end_addr = strtoull(argv[i] + 4, NULL, 16) & ~1ULL;
        } else if (strncmp(argv[i], "out=", 4) == 0) {
            path = argv[i] + 4;
        } else if (strncmp(argv[i], "profile=", 8) == 0) {
            profile_path = argv[i] + 8;
        } else {
            fprintf(stderr, "icount: unknown argument %s (begin=HEX,end=HEX,out=FILE[,profile=FILE])\n",
                    argv[i]);
            return -1;
        }
    }
    if (begin_addr == 0 || end_addr == 0 || path == NULL) {
        fprintf(stderr, "icount: needs begin=HEX,end=HEX,out=FILE\n");
        return -1;
    }
    out = fopen(path, "w");
    if (out == NULL) {
        perror(path);
        return -1;
    }
    if (profile_path != NULL) {
        profile = calloc(CODE_BYTES / 2, sizeof *profile);
        if (profile == NULL) {
            perror("icount: profile");
            return -1;
        }
    }
    qemu_plugin_register_vcpu_tb_trans_cb(id, on_translate);
    qemu_plugin_register_atexit_cb(id, on_qemu_exit, NULL);
    return 0;
}
