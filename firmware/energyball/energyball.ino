/* EnergyBall arm tracker firmware: Adafruit Metro Mini (ATmega328P, 16 MHz), an
 * MPU-9250 on I2C and a flex sensor through an op-amp on A0 (Zhu & Shi,
 * "Motion Control in VR", sec. 4), streaming the wire protocol of
 * firmware/PROTOCOL.md at 500000 baud: RAW frames (sensor counts) with a TEMP frame
 * (the MPU's die temperature) once a second, or FUSED frames (the paper's
 * complementary filter, sec. 3, run on the board, and the flex angle of eq. 3). Built
 * with -DEB_LEGACY_TEXT=1 (make LEGACY_TEXT=1) it prints the paper's text lines at
 * 9600 baud instead (PROTOCOL.md sec. 10).
 *
 * Timing: Timer1 raises an interrupt at each sample instant (sampler.cpp); the
 * loop serves host commands, takes the samples due, and sends status. Nothing
 * waits on delay() once running (but re-configuring an IMU that lost power), every
 * I2C transfer has a timeout, and a watchdog resets a board whose loop stops.
 *
 * Phase markers, for cycle counting by the AVR simulator harness (firmware/sim/):
 * PORTB pins written directly (one sbi/cbi instruction each),
 *   PB0 (D8)  high while reading the sensors (I2C and ADC),
 *   PB1 (D9)  high while computing and encoding (filter, framing),
 *   PB2 (D10) high while handing the frame's bytes to Serial (and, once a second in
 *             RAW mode, encoding and handing over the TEMP frame that goes before it).
 * D13 (PB5) is the status LED: steady while measuring the gyroscope bias at boot
 * (keep still), a 50 ms flash a second while streaming, a slow blink when stopped,
 * a fast 5 Hz blink while the IMU is missing or failing.
 */
#include <avr/eeprom.h>
#include <avr/wdt.h>

#include "imu.h"
#include "sampler.h"
#include "src/eb_bias.h"
#include "src/eb_board.h"
#include "src/eb_budget.h"
#include "src/eb_clock.h"
#include "src/eb_filter.h"
#include "src/eb_protocol.h"
#include "src/eb_sensors.h"
#include "src/eb_text.h"

#define PHASE_READ _BV(PB0)
#define PHASE_COMPUTE _BV(PB1)
#define PHASE_SEND _BV(PB2)
#define LED_PIN_MASK _BV(PB5)
#define PHASE_ON(mask) (PORTB |= (mask))
#define PHASE_OFF(mask) (PORTB &= (uint8_t)~(mask))

#if EB_LEGACY_TEXT
static const uint32_t BAUD = 9600;
static const uint16_t LEGACY_LINES_HZ = 20; /* a 40-byte line at 9600 baud: 83% of the link */
#else
static const uint32_t BAUD = EB_BAUD; /* the rate limits follow it (eb_budget.h) */
#endif
static const uint8_t FLEX_CHANNEL = 0; /* A0 */
static const uint8_t FLEX_OVERSAMPLE = 4; /* 4 conversions of 104 us, averaged */
static const uint8_t I2C_FAILURES_TO_LOSE_IMU = 10; /* consecutive, then re-initialise */
static uint8_t *const BIAS_EEPROM = (uint8_t *)0;

/* One sample as read. */
struct Reading {
    int16_t acc[3], gyr[3];
    int16_t temp; /* TEMP_OUT, from the same burst */
    uint16_t flex_sum; /* FLEX_OVERSAMPLE 10-bit conversions */
};

static eb_state_t state;
static eb_grid_t grid; /* stamp of the next due sample */
static eb_filter_t filter;
static Imu imu;
static int16_t gyro_bias[3]; /* counts, for the on-board filter only: RAW frames are as read */
static uint32_t filter_t_us; /* stamp of the filter's last sample */
static bool filter_timed; /* filter_t_us holds: the filter has run since it was (re)started */
static uint16_t errors; /* EB_ERR_* */
static bool imu_ready;
static uint8_t i2c_failures;
static eb_rail_t flex_rail;
static uint32_t clock_epoch_us; /* micros() at power-up: device time 0 */
static uint32_t last_status_ms;
#if EB_LEGACY_TEXT
static uint16_t legacy_countdown;
#else
static eb_parser_t parser;
#endif

static uint32_t device_us()
{
    return micros() - clock_epoch_us;
}

/* ------------------------------------------------------------ sending */

static void send_reply(const uint8_t *frame, size_t n)
{
#if !EB_LEGACY_TEXT
    Serial.write(frame, n); /* replies wait for room in the TX buffer */
#else
    (void)frame;
    (void)n;
#endif
}

/* Sample frames never wait: one the TX buffer cannot take now is lost on the wire
 * (a seq gap to the host, PROTOCOL.md 7.5); so is a TEMP frame. Whether it went. */
static bool send_sample(const uint8_t *frame, size_t n)
{
    if ((size_t)Serial.availableForWrite() < n)
        return false;
    Serial.write(frame, n);
    return true;
}

static void send_hello()
{
    eb_hello_t h = {EB_FW_MAJOR, EB_FW_MINOR, EB_FW_PATCH, imu.whoami, imu.mag_whoami,
                    state.rate_hz, state.mode, state.streaming, EB_ACC_FS, EB_GYR_FS, errors};
    uint8_t frame[EB_FRAME_SIZE(EB_HELLO_LEN)];
    send_reply(frame, eb_encode_hello(frame, &h));
    errors &= (uint16_t)~EB_EVENT_BITS; /* events are reported once */
    last_status_ms = millis();
}

/* ------------------------------------------------------------ status LED */

/* The LED at this moment of one of eb_board.h's patterns (EB_LED_*). */
static void show_led(uint8_t pattern)
{
    if (eb_led_on(pattern, millis()))
        PORTB |= LED_PIN_MASK;
    else
        PORTB &= (uint8_t)~LED_PIN_MASK;
}

/* ------------------------------------------------------------ sensors */

/* The IMU and infrared hand-tracking paper's eq. 2, at boot: if the gyroscope is
 * still, its mean is the bias, kept in EEPROM; a board moved during boot reuses the
 * stored one. */
static void measure_gyro_bias()
{
    eb_still_t still;
    eb_still_init(&still);
    show_led(EB_LED_CALIBRATING); /* steady: keep still */
    delay(EB_BIAS_SETTLE_MS); /* the gyroscope starts and the DLPF settles */
    for (uint8_t i = 0; i < EB_BIAS_SAMPLES; i++) {
        int16_t acc[3], gyr[3], temp;
        wdt_reset();
        if (imu_read(acc, gyr, &temp) != IMU_READ_OK)
            break;
        eb_still_add(&still, gyr, acc);
        delayMicroseconds(1000); /* the MPU's internal rate: a new sample each ms */
    }
    uint8_t record[EB_BIAS_RECORD_SIZE];
    if (eb_still_is_still(&still)) {
        eb_still_mean(&still, gyro_bias);
        eb_bias_pack(record, gyro_bias);
        eeprom_update_block(record, BIAS_EEPROM, sizeof record);
    } else {
        eeprom_read_block(record, BIAS_EEPROM, sizeof record);
        if (!eb_bias_unpack(record, gyro_bias))
            gyro_bias[0] = gyro_bias[1] = gyro_bias[2] = 0;
    }
}

static void init_imu(uint32_t powered_ms)
{
    uint16_t found = imu_init(imu, state.rate_hz, powered_ms);
    errors = (uint16_t)((errors & ~(EB_ERR_IMU_MISSING | EB_ERR_MAG_MISSING)) | found);
    imu_ready = !(found & (EB_ERR_IMU_MISSING | EB_ERR_I2C_FAILURE));
    i2c_failures = 0;
}

static void bring_up_imu()
{
    init_imu(0); /* at boot, or a second after it was lost: its start-up is long past */
    if (imu_ready)
        measure_gyro_bias();
}

static void note_i2c(bool ok)
{
    if (ok) {
        i2c_failures = 0;
        return;
    }
    errors |= EB_ERR_I2C_FAILURE;
    if (++i2c_failures >= I2C_FAILURES_TO_LOSE_IMU) {
        imu_ready = false; /* retried once a second from the loop */
        errors |= EB_ERR_IMU_MISSING;
    }
}

/* Only RAW frames carry the magnetometer; the filter does not use it. */
static bool mag_wanted()
{
#if EB_LEGACY_TEXT
    return false;
#else
    return imu.mag_whoami && state.mode == EB_MODE_RAW;
#endif
}

/* The flex conversions run during the I2C transfers instead of after them: each one's
 * interrupt adds its result and starts the next, FLEX_OVERSAMPLE x 13 ADC clocks at
 * 125 kHz = 416 us (DS40002061 sec. 24.4), done well within the MPU's 1.9 ms burst;
 * analogRead's waiting cost 6,700 cycles a sample. */
static volatile uint16_t flex_sum;
static volatile uint8_t flex_left;

ISR(ADC_vect)
{
    flex_sum += ADC;
    if (--flex_left)
        ADCSRA |= _BV(ADSC);
    else
        ADCSRA &= (uint8_t)~_BV(ADIE);
}

/* The core's init() has enabled the ADC with its 125 kHz clock; AVcc is analogRead's
 * DEFAULT reference. Setting ADIE writes ADIF back too, clearing a stale flag. */
static void start_flex()
{
    flex_sum = 0;
    flex_left = FLEX_OVERSAMPLE;
    ADMUX = _BV(REFS0) | FLEX_CHANNEL;
    ADCSRA |= _BV(ADIE) | _BV(ADSC);
}

static uint16_t finish_flex()
{
    while (flex_left) {
    }
    return flex_sum;
}

static bool read_sensors(Reading &r)
{
    PHASE_ON(PHASE_READ);
    start_flex();
    ImuRead got = imu_read(r.acc, r.gyr, &r.temp);
    note_i2c(got == IMU_READ_OK);
    if (got == IMU_READ_OK && mag_wanted())
        note_i2c(imu_read_mag(imu));
    r.flex_sum = finish_flex();
    PHASE_OFF(PHASE_READ);
    if (got == IMU_READ_RESET)
        init_imu(millis()); /* it lost power, perhaps this very moment: wait for its start-up and
                               configure it again (I2C_FAILURE is reported; the bias is kept) */
    return got == IMU_READ_OK;
}

static uint16_t flex_adc(const Reading &r)
{
    return (uint16_t)((r.flex_sum + FLEX_OVERSAMPLE / 2) / FLEX_OVERSAMPLE);
}

/* ------------------------------------------------------------ samples */

static void restart_filter()
{
    eb_filter_init(&filter, EB_FILTER_ALPHA);
    filter_timed = false;
}

/* The filter integrates the time since its last sample, skipped samples included
 * (a late loop, a failed read): the first sample after a (re)start, one period. */
static void update_filter(const Reading &r, uint32_t t_us)
{
    float gyr[3], acc[3];
    for (uint8_t i = 0; i < 3; i++) {
        gyr[i] = eb_gyr_rad_s(eb_gyr_unbiased(r.gyr[i], gyro_bias[i]), EB_GYR_FS);
        acc[i] = eb_acc_m_s2(r.acc[i], EB_ACC_FS);
    }
    float dt = filter_timed ? (float)(t_us - filter_t_us) * 1e-6f : 1.0f / state.rate_hz;
    eb_filter_update(&filter, gyr, acc, dt);
    filter_t_us = t_us;
    filter_timed = true;
}

static float flex_deg(const Reading &r)
{
    return eb_flex_deg((float)r.flex_sum / FLEX_OVERSAMPLE);
}

#if EB_LEGACY_TEXT
static void emit_sample(const Reading &r, uint32_t t_us)
{
    PHASE_ON(PHASE_COMPUTE);
    update_filter(r, t_us);
    bool line_due = --legacy_countdown == 0;
    char line[EB_TEXT_LINE_MAX];
    size_t n = 0;
    if (line_due) {
        legacy_countdown = state.rate_hz / LEGACY_LINES_HZ;
        n = eb_format_text_line(line, filter.q, flex_deg(r));
    }
    PHASE_OFF(PHASE_COMPUTE);
    if (line_due) {
        PHASE_ON(PHASE_SEND);
        send_sample((const uint8_t *)line, n);
        PHASE_OFF(PHASE_SEND);
    }
}
#else
static void emit_sample(const Reading &r, uint32_t t_us)
{
    uint8_t frame[EB_MAX_BOARD_FRAME];
    size_t n;
    bool temp = false; /* a TEMP frame goes first (PROTOCOL.md 4.3) */
    PHASE_ON(PHASE_COMPUTE);
    if (state.mode == EB_MODE_FUSED) {
        update_filter(r, t_us);
        eb_fused_t s = {t_us, state.seq, {filter.q[0], filter.q[1], filter.q[2], filter.q[3]},
                        flex_deg(r)};
        n = eb_encode_fused(frame, &s);
    } else {
        eb_raw_t s = {t_us, state.seq, {r.acc[0], r.acc[1], r.acc[2]}, {r.gyr[0], r.gyr[1], r.gyr[2]},
                      {imu.mag.mag[0], imu.mag.mag[1], imu.mag.mag[2]}, flex_adc(r), EB_ACC_FS,
                      EB_GYR_FS, imu_mag_valid(imu), imu_mag_valid(imu) && imu.mag.overflow};
        n = eb_encode_raw(frame, &s);
        temp = eb_temp_due(&state);
    }
    PHASE_OFF(PHASE_COMPUTE);
    PHASE_ON(PHASE_SEND);
    /* PROTOCOL.md 4.3: the die temperature of this burst right before the first RAW frame
     * sent since power-up, RESET, START or the switch to RAW, then again once rate_hz RAW
     * frames have been sent since the last one (once a second). A RAW frame not sent is not
     * counted: its TEMP frame goes again before the next. */
    if (temp) {
        uint8_t t[EB_FRAME_SIZE(EB_TEMP_LEN)];
        send_sample(t, eb_encode_temp(t, t_us, r.temp));
    }
    if (send_sample(frame, n) && state.mode == EB_MODE_RAW)
        eb_count_raw(&state, temp);
    PHASE_OFF(PHASE_SEND);
}
#endif

static void take_sample(uint32_t t_us)
{
    Reading r;
    if (!read_sensors(r))
        return; /* not taken, not numbered: the host sees the time jump */
    if (eb_rail_update(&flex_rail, flex_adc(r), state.rate_hz))
        errors |= EB_ERR_FLEX_RAIL;
    else
        errors &= (uint16_t)~EB_ERR_FLEX_RAIL;
    emit_sample(r, t_us);
    state.seq++;
}

/* PROTOCOL.md 7.4: of the samples due, only the most recent is taken; older ones are
 * skipped (and OVERRUN reported), since the sensors can only be read now: a sample's
 * data is read less than one period after its stamp. Not streaming, or without an IMU,
 * the grid moves on and nothing is numbered (and the filter's clock starts again). */
static void run_due_samples()
{
    uint16_t n = sampler_take();
    if (!n)
        return;
    if (n > 1 && state.streaming)
        errors |= EB_ERR_OVERRUN;
    for (; n > 1; n--)
        eb_grid_advance(&grid);
    if (state.streaming && imu_ready)
        take_sample(grid.t_us);
    else
        filter_timed = false;
    eb_grid_advance(&grid);
}

/* Sample k of the current rate's grid is the next one; the timer's first
 * interrupt falls on it (or it is due at once if that instant has passed). */
static void start_sampling(uint32_t k)
{
    eb_grid_set(&grid, state.rate_hz, k);
    eb_grid_t next = grid;
    eb_grid_advance(&next);
    int32_t wait = (int32_t)(grid.t_us - device_us());
    if (wait > 0) {
        sampler_start(state.rate_hz, (uint32_t)wait, false);
    } else {
        wait = (int32_t)(next.t_us - device_us());
        sampler_start(state.rate_hz, wait > 0 ? (uint32_t)wait : 1u, true);
    }
}

/* PROTOCOL.md 7.1: seq 0, clock from 0, boot configuration, stream. The caller sends
 * the HELLO that follows (setup, or a RESET command's reply). */
static void power_up()
{
    eb_state_power_up(&state);
    restart_filter();
    if (imu_ready)
        imu_set_rate(state.rate_hz);
#if EB_LEGACY_TEXT
    legacy_countdown = 1;
#endif
    clock_epoch_us = micros();
    start_sampling(0);
}

/* ------------------------------------------------------------ commands */

#if !EB_LEGACY_TEXT
static void execute(const eb_command_t &c)
{
    eb_reply_t r = eb_execute(&state, &c);
    if (r.ack) {
        uint8_t frame[EB_FRAME_SIZE(EB_ACK_LEN)];
        send_reply(frame, eb_encode_ack(frame, c.type, r.status));
    }
    switch (r.action) {
    case EB_ACTION_RETIME: /* the clock runs on; the new grid's next point after now */
        if (imu_ready)
            note_i2c(imu_set_rate(state.rate_hz));
        start_sampling(eb_grid_first_after(state.rate_hz, device_us()));
        break;
    case EB_ACTION_MODE:
        restart_filter(); /* fused mode levels from its first sample */
        break;
    case EB_ACTION_RESET:
        power_up(); /* eb_execute asks for the HELLO after it, as after IDENTIFY */
        break;
    }
    if (r.hello)
        send_hello();
}
#endif

static void serve_commands()
{
#if EB_LEGACY_TEXT
    while (Serial.available()) /* the paper's sketch ignores its input */
        Serial.read();
#else
    while (Serial.available()) {
        eb_parser_push(&parser, (uint8_t)Serial.read());
        eb_command_t c;
        while (eb_parser_next(&parser, &c))
            execute(c);
    }
#endif
}

/* ------------------------------------------------------------ health */

/* Once a second while something is wrong: retry a missing IMU and send a status HELLO. */
static void check_health()
{
    if (millis() - last_status_ms < EB_STATUS_PERIOD_MS)
        return;
    if (!imu_ready)
        bring_up_imu(); /* imu_init configures the current rate's filter */
    if (errors & EB_STATUS_BITS)
        send_hello();
    else
        last_status_ms = millis();
}

static void show_status_led()
{
    show_led(!imu_ready ? EB_LED_ERROR : state.streaming ? EB_LED_STREAMING : EB_LED_IDLE);
}

/* ------------------------------------------------------------ watchdog */

/* A hang (a wait that never ends, a corrupted return address) resets the board.
 * The longest legitimate stretch without wdt_reset() is the IMU's set-up and the
 * gyroscope's settling before the boot bias, about 310 ms (WHO_AM_I within the
 * start-up time, 100 ms after H_RESET, EB_BIAS_SETTLE_MS). */
static const uint8_t WATCHDOG_PERIOD = WDTO_500MS;

/* After a watchdog reset the watchdog stays on at its shortest period (16 ms), as
 * WDRF in MCUSR forces WDE (DS40002061, WDTCSR); Optiboot clears it, but the board
 * must not depend on its bootloader. So before main(): clear WDRF, then turn it off. */
void watchdog_off_at_start() __attribute__((naked, used, section(".init3")));
void watchdog_off_at_start()
{
    MCUSR = 0;
    wdt_disable();
}

/* ------------------------------------------------------------ Arduino */

void setup()
{
    wdt_enable(WATCHDOG_PERIOD);
    DDRB |= PHASE_READ | PHASE_COMPUTE | PHASE_SEND | LED_PIN_MASK;
    Serial.begin(BAUD);
    state.rate_hz = EB_BOOT_RATE_HZ; /* for the DLPF at bring-up */
    bring_up_imu();
    power_up();
    send_hello();
}

void loop()
{
    wdt_reset();
    serve_commands();
    run_due_samples();
    check_health();
    show_status_led();
}
