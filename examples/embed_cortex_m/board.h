/* What startup.c gives main.c: text out and exit over semihosting, and a tick counter. */
#ifndef BOARD_H
#define BOARD_H
#include <stdint.h>
void board_write(const char *text);
void board_exit(int status);
uint32_t board_ticks(void);   /* SysTick's current value: counts DOWN, 24 bits */
#endif
