/* The highest sample rate the board sustains in each mode, computed in one place
 * from the clocks: the CPU's, the I2C bus's and the UART's. SET_RATE (and SET_MODE)
 * refuse a rate above it with BAD_ARGUMENT (PROTOCOL.md sec. 6 and 7.5).
 *
 * One sample costs the CPU, in cycles at F_CPU:
 *   EB_READ_CYCLES                  the read phase besides the bus: the Wire library's
 *                                   code and 4 flex conversions (4 x 13 ADC clocks at
 *                                   125 kHz = 416 us, ATmega328P data sheet sec. 24.4)
 *   EB_I2C_BITS_PER_SAMPLE x SCL    the bus: the CPU waits for it
 *   EB_RAW_CYCLES / EB_FUSED_CYCLES compute and send (filter, framing, copy to Serial)
 *   frame bytes x EB_UART_ISR_CYCLES the UART's data-register-empty interrupt per byte
 * and the link carries a frame in frame bytes x 10 bit times (8N1) at the baud the
 * UART really runs at. A rate is sustained when both fit in EB_BUDGET_PERCENT of a
 * second; the rest is kept for command replies, status HELLOs, the timer interrupts
 * and the loop's own jitter.
 *
 * The cycle figures are measured: firmware/sim/boardsim reports each phase's mean
 * cycles without simavr's bus time (README.md, "Rate limits", has the command and
 * tests/firmware/test_sim.py checks these constants still cover what it measures).
 */
#ifndef EB_BUDGET_H
#define EB_BUDGET_H

#include <stdbool.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define EB_I2C_CLOCK_HZ 400000ul /* fast mode (MPU-9250 product specification sec. 3.6: up to 400 kHz) */
#define EB_BAUD 115200ul /* the binary protocol's (PROTOCOL.md sec. 1) */

/* Measured at 200 Hz (README.md, "Rate limits"): read 12337 (RAW) and 12723 (FUSED),
 * compute + send 3711 + 3771 (RAW) and 39349 + 2571 (FUSED), with some margin. */
#define EB_READ_CYCLES 13000u
#define EB_RAW_CYCLES 7700u
#define EB_FUSED_CYCLES 42500u
/* One MPU-9250 burst (START, address, register, repeated START, address, 14 bytes,
 * STOP) and one AK8963 read (the same with 8 bytes): 9 SCL periods a byte (8 bits and
 * the acknowledge, NXP UM10204 sec. 3.1.6) and one per START or STOP condition,
 * (3 + 14) x 9 + 3 + (3 + 8) x 9 + 3 = 258. */
#define EB_I2C_BITS_PER_SAMPLE 258u
/* HardwareSerial's USART_UDRE vector: 15 registers saved and restored, the call to
 * _tx_udr_empty_irq and its 34 instructions (counted in avr-objdump -d), about 140. */
#define EB_UART_ISR_CYCLES 140u
#define EB_BUDGET_PERCENT 90u

/* The baud the UART really runs at for a requested one: the Arduino core's double-speed
 * setting UBRR = (cpu / 4 / baud - 1) / 2, and baud = cpu / (8 (UBRR + 1)) (ATmega328P
 * data sheet table 20-1): 117647 for 115200 at 16 MHz, exact for 250000 and 500000. */
uint32_t eb_uart_baud(uint32_t cpu_hz, uint32_t baud);
/* The highest rate (Hz) sustained in mode with these clocks, at most EB_MAX_RATE_HZ. */
uint16_t eb_max_rate_hz(uint8_t mode, uint32_t cpu_hz, uint32_t i2c_hz, uint32_t baud);
/* Whether this board (F_CPU, EB_I2C_CLOCK_HZ, EB_BAUD) takes rate_hz in mode. */
bool eb_rate_valid(uint16_t rate_hz, uint8_t mode);

#ifdef __cplusplus
}
#endif

#endif
