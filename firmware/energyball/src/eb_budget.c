#include "eb_budget.h"

#include "eb_clock.h"
#include "eb_protocol.h"

#ifndef F_CPU
#define F_CPU 16000000ul /* the host build: the Metro Mini's clock */
#endif

uint32_t eb_uart_baud(uint32_t cpu_hz, uint32_t baud)
{
    uint32_t ubrr = (cpu_hz / 4u / baud - 1u) / 2u;
    return cpu_hz / (8u * (ubrr + 1u));
}

uint16_t eb_max_rate_hz(uint8_t mode, uint32_t cpu_hz, uint32_t i2c_hz, uint32_t baud)
{
    bool fused = mode == EB_MODE_FUSED;
    uint32_t frame = fused ? EB_FRAME_SIZE(EB_FUSED_LEN) : EB_FRAME_SIZE(EB_RAW_LEN);
    /* SCL period: 16 + 2 TWBR cycles with Wire's TWBR = (cpu / scl - 16) / 2 (data sheet
     * sec. 22.5.2) */
    uint32_t scl_cycles = 16u + 2u * ((cpu_hz / i2c_hz - 16u) / 2u);
    uint32_t cycles = EB_READ_CYCLES + EB_MPU_BITS * scl_cycles +
                      (fused ? EB_FUSED_CYCLES : EB_RAW_CYCLES) + frame * EB_UART_ISR_CYCLES;
    uint32_t budget = cpu_hz / 100u * EB_BUDGET_PERCENT;
    if (!fused) /* the AK8963 at its own rate, whatever the sample rate (above it) */
        budget -= EB_MAG_READS_HZ * EB_MAG_BITS * scl_cycles;
    uint32_t by_cpu = budget / cycles;
    uint32_t by_link = eb_uart_baud(cpu_hz, baud) / 10u * EB_BUDGET_PERCENT / 100u / frame;
    uint32_t rate = by_cpu < by_link ? by_cpu : by_link;
    return (uint16_t)(rate < EB_MAX_RATE_HZ ? rate : EB_MAX_RATE_HZ);
}

bool eb_rate_valid(uint16_t rate_hz, uint8_t mode)
{
    return rate_hz >= EB_MIN_RATE_HZ && rate_hz <= eb_max_rate_hz(mode, F_CPU, EB_I2C_CLOCK_HZ, EB_BAUD);
}
