/*
 * eomc's float C on a Cortex-M4: a 7-dof arm's rhs and jac_x, a quadruped's rhs (floating
 * base), evaluated at pseudo-random states drawn here, printed bit-exactly (hex of the float)
 * for the host to check against its double build.  Also one NAME_step_rk4 and the SysTick
 * ticks per call (under QEMU's -icount they count instructions, see the Makefile).
 *
 * Output lines:  <model> <what> <status> <hex float> ...
 */
#include <stdint.h>
#include <string.h>

#include "arm.h"
#include "board.h"
#include "quad.h"

#define NSTATES 8
#define NTIMED 4

static char line[16 * (ARM_NX * ARM_NX) + 64];

static uint32_t next_random(uint32_t *seed)
{
    *seed = (*seed * 1664525u) + 1013904223u;
    return *seed >> 8;
}

static float uniform(uint32_t *seed, float lo, float hi)
{
    return lo + ((hi - lo) * ((float)next_random(seed) * (1.0f / 16777216.0f)));
}

static void emit(const char *model, const char *what, int status, const float *v, int n)
{
    static const char hex[] = "0123456789abcdef";
    size_t at = 0;
    int i, k;
    uint32_t bits;
    at += strlen(strcpy(line + at, model));
    line[at++] = ' ';
    at += strlen(strcpy(line + at, what));
    line[at++] = ' ';
    line[at++] = (char)('0' + status);
    for (i = 0; i < n; i++) {
        memcpy(&bits, &v[i], sizeof bits);
        line[at++] = ' ';
        for (k = 7; k >= 0; k--) {
            line[at++] = hex[(bits >> (4 * k)) & 0xFu];
        }
    }
    line[at++] = '\n';
    line[at] = '\0';
    board_write(line);
}

static void emit_count(const char *what, uint32_t ticks)
{
    float v = (float)ticks;
    emit("ticks", what, 0, &v, 1);
}

static void draw(uint32_t *seed, float *x, int nq, int nx, float angle)
{
    int i;
    for (i = 0; i < nx; i++) {
        x[i] = (i < nq) ? uniform(seed, -angle, angle) : uniform(seed, -1.0f, 1.0f);
    }
}

int main(void)
{
    static float x[QUAD_NX > ARM_NX ? QUAD_NX : ARM_NX];
    static float out[ARM_NX * ARM_NX];
    float work[ARM_WORK_LEN > QUAD_WORK_LEN ? ARM_WORK_LEN : QUAD_WORK_LEN];
    float r[ARM_NINPUT > 0 ? ARM_NINPUT : 1] = {0.0f};
    float rq[QUAD_NINPUT > 0 ? QUAD_NINPUT : 1] = {0.0f};
    uint32_t seed = 12345u, t0, t1;
    int s, k, status, failures = 0;

    for (s = 0; s < NSTATES; s++) {
        draw(&seed, x, ARM_NQ, ARM_NX, 2.0f);
        emit("arm", "x", 0, x, ARM_NX);
        status = arm_rhs(0.0f, x, arm_param_defaults, r, out, work);
        failures += (status != 0);
        emit("arm", "rhs", status, out, ARM_NX);
        status = arm_jac_x(0.0f, x, arm_param_defaults, r, out, work);
        failures += (status != 0);
        emit("arm", "jac_x", status, out, ARM_NX * ARM_NX);
    }
    for (s = 0; s < NSTATES; s++) {
        draw(&seed, x, QUAD_NQ, QUAD_NX, 0.5f);
        x[2] += 0.3f;   /* the base above the ground */
        emit("quad", "x", 0, x, QUAD_NX);
        status = quad_rhs(0.0f, x, quad_param_defaults, rq, out, work);
        failures += (status != 0);
        emit("quad", "rhs", status, out, QUAD_NX);
    }
    /* one RK4 step of the arm from the last arm state drawn again */
    seed = 777u;
    draw(&seed, x, ARM_NQ, ARM_NX, 2.0f);
    emit("arm", "x", 0, x, ARM_NX);
    status = arm_step_rk4(0.0f, 0.001f, x, arm_param_defaults, r, work);
    failures += (status != 0);
    emit("arm", "step_rk4", status, x, ARM_NX);

    /* ticks per call, NTIMED calls each (SysTick counts down) */
    t0 = board_ticks();
    for (k = 0; k < NTIMED; k++) {
        (void)arm_rhs(0.0f, x, arm_param_defaults, r, out, work);
    }
    t1 = board_ticks();
    emit_count("arm_rhs", ((t0 - t1) & 0x00FFFFFFu) / NTIMED);
    t0 = board_ticks();
    for (k = 0; k < NTIMED; k++) {
        (void)arm_jac_x(0.0f, x, arm_param_defaults, r, out, work);
    }
    t1 = board_ticks();
    emit_count("arm_jac_x", ((t0 - t1) & 0x00FFFFFFu) / NTIMED);
    draw(&seed, x, QUAD_NQ, QUAD_NX, 0.5f);
    t0 = board_ticks();
    for (k = 0; k < NTIMED; k++) {
        (void)quad_rhs(0.0f, x, quad_param_defaults, rq, out, work);
    }
    t1 = board_ticks();
    emit_count("quad_rhs", ((t0 - t1) & 0x00FFFFFFu) / NTIMED);
    /* calibration: a loop of a known instruction count (subs + bne = 2 per turn, 10000 turns) */
    t0 = board_ticks();
    __asm__ volatile("movw r3, #10000\n1:\n\tsubs r3, r3, #1\n\tbne 1b" ::: "r3", "cc");
    t1 = board_ticks();
    emit_count("calibration_20000_instructions", (t0 - t1) & 0x00FFFFFFu);
    board_write(failures == 0 ? "done\n" : "failed\n");
    return failures == 0 ? 0 : 1;
}
