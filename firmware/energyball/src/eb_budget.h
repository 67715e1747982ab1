/* The highest sample rate the board sustains in each mode, computed in one place
 * from the clocks: the CPU's, the I2C bus's and the UART's. SET_RATE (and SET_MODE)
 * refuse a rate above it with BAD_ARGUMENT (PROTOCOL.md sec. 6 and 7.5).
 *
 * One sample costs the CPU, in cycles at F_CPU:
 *   EB_READ_CYCLES                  the read phase besides the bus: the Wire library's
 *                                   code and the interrupts of 4 flex conversions (which
 *                                   run during the bus transfer)
 *   EB_MPU_BITS x SCL               the MPU-9250's burst: the CPU waits for the bus
 *   EB_RAW_CYCLES / EB_FUSED_CYCLES compute and send (filter, framing, copy to Serial)
 *   frame bytes x EB_UART_ISR_CYCLES the UART's data-register-empty interrupt per byte
 * and in RAW mode the AK8963 is read EB_MAG_READS_HZ times a second at most (EB_MAG_BITS
 * x SCL each). The link carries a frame in frame bytes x 10 bit times (8N1) at the baud
 * the UART really runs at. A rate is sustained when both fit in EB_BUDGET_PERCENT of a
 * second; the rest is kept for command replies, status HELLOs, TEMP frames, the timer
 * interrupts and the loop's own jitter. A TEMP frame (PROTOCOL.md sec. 4.3, RAW mode only)
 * is 12 bytes and about 3000 cycles (measured) once a second whatever the rate: 0.024% of
 * the link at 500000 baud and 0.02% of the CPU, too little to count.
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

/* Standard mode. Over an arm-length cable with the breakout's 10 kOhm pull-ups the
 * rise time is t_r = 0.8473 R C_b (UM10204 rev. 7, sec. 7.1): with C_b = 80 pF (about
 * 0.75 m of cable at 70 pF/m, two 10 pF pins, PCB) that is 680 ns, over Fast-mode's
 * 300 ns but within Standard-mode's 1000 ns (UM10204 table 10). firmware/README.md
 * has the sums and the sample budget. */
#define EB_I2C_CLOCK_HZ 100000ul
/* The binary protocol's (PROTOCOL.md sec. 1). Exact at 16 MHz: the core sets U2X0 and
 * UBRR0 = 3, 16e6 / (8 * 4) = 500000 (DS40002061 table 20-1), where 115200 gives
 * UBRR0 = 16, 117647 baud, 2.1% fast: past the receiver's recommended +-1.5% (table
 * 20-3) for the host's commands. The CP2104 makes 500000 exactly too (48 MHz / 96, its
 * data sheet sec. 6.1). */
#define EB_BAUD 500000ul

/* Measured with firmware/sim/boardsim at 100 kHz and 500000 baud, 200 Hz, a still board
 * with the data sheets' noise (firmware/README.md, "Rate limits"): read 4641 (RAW) and
 * 3682 (FUSED) besides the bus, compute + send 2347 + 5284 (RAW, the TEMP frames
 * included) and 26325 + 3555 (FUSED), with some margin; the UART's interrupts
 * (EB_UART_ISR_CYCLES a byte, counted apart) fall into these phases. A FUSED sample whose tilt is more than 11 degrees off
 * takes the filter's exact path, up to 3000 cycles more (firmware/README.md): the 10%
 * that EB_BUDGET_PERCENT keeps covers it. */
#define EB_READ_CYCLES 5200u
#define EB_RAW_CYCLES 7700u
#define EB_FUSED_CYCLES 31000u
/* I2C bits: 9 SCL periods a byte (8 bits and the acknowledge, NXP UM10204 sec. 3.1.6)
 * and one per START, repeated START or STOP condition. The MPU-9250's burst (address,
 * register, address again, 18 bytes from INT_PIN_CFG, imu.cpp) is (3 + 18) x 9 + 3;
 * the AK8963's (ST1..ST2, 8 bytes) (3 + 8) x 9 + 3, once per its 100 Hz measurement
 * (continuous mode 2, AK8963 data sheet MS1356-E-02 sec. 6.4.3). */
#define EB_MPU_BITS 192u
#define EB_MAG_BITS 102u
#define EB_MAG_READS_HZ 100u
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
