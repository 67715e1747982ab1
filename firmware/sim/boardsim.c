/*
 * boardsim - run the EnergyBall firmware ELF on a simulated ATmega328P.
 *
 *   boardsim ELF [--pty LINK] [--motion CSV] [--interp linear|hold]
 *                [--flex-mv MV] [--flex-swing LO,HI] [--no-imu] [--seed N]
 *                [--noise | --no-noise] [--eeprom-bias X,Y,Z] [--seconds S]
 *                [--speed X] [--reset-on-open | --no-reset-on-open]
 *                [--bootloader-ms MS] [--host-baud B] [--baud-error HOST[,AVR]] [--json]
 *                [--verbose] [--imu-startup-ms MS] [--reset-at S] [--stuck-sda]
 *                [--glitch T] [--glitch-in-read] [--hang-at S]
 *
 * The board (simavr 1.6, 16 MHz): a virtual MPU-9250 + AK8963 on the TWI
 * bus (imu.c), a flex voltage on ADC0 with AVCC = AREF = 5 V, UART0 bridged
 * to a pty (simavr's uart_pty part) whose slave LINK points to, and the
 * loop-phase pins PB0..PB2 timed in CPU cycles (phases.c). The host opening
 * the pty resets the board into its bootloader, and each end's real baud rate
 * decides whether the other can read it (host_port.c, serial_line.c). With
 * --json a report goes to stdout at the end; messages go to stderr.
 *
 * See firmware/sim/README.md.
 */
#define _GNU_SOURCE
#include <ctype.h>
#include <errno.h>
#include <fcntl.h>
#include <getopt.h>
#include <math.h>
#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include <avr_adc.h>
#include <avr_eeprom.h>
#include <avr_ioport.h>
#include <avr_twi.h>
#include <avr_uart.h>
#include <sim_avr.h>
#include <sim_elf.h>
#include <sim_irq.h>
#include <uart_pty.h>

#include "eb_bias.h"
#include "eb_protocol.h"
#include "frames.h"
#include "i2cbus.h"
#include "host_port.h"
#include "imu.h"
#include "motion.h"
#include "phases.h"
#include "recovery.h"
#include "serial_line.h"

DEFINE_FIFO(uint8_t, uart_pty_fifo); /* accessors of the pty part's byte queues */

#define MCU "atmega328p"
#define F_CPU 16000000u
#define VCC_MV MOTION_VCC_MV
#define PACE_CYCLES (F_CPU / 1000) /* check the wall clock every simulated ms */
#define EM_AVR_MACHINE 83          /* ELF e_machine of Atmel AVR */
#define PTY_FIFO_HIGH 384          /* bytes queued to the pty: wait for the host */
#define MAX_SECONDS 1e6            /* --seconds: 11.6 simulated days (far more overflows the cycle count) */
#define MIN_SPEED 1e-3             /* --speed above 0: a simulated ms in at most 1 s of wall time */
/* Simulated time 0 is the AVR's first instruction; the supply came up earlier. The Uno's
 * (and Metro Mini's) low fuse 0xFF selects the full-swing crystal with SUT = 11: reset
 * is held 16K CK + 14 CK + 65 ms after power-on (DS40002061, "Start-up Times for the
 * Full Swing Crystal Oscillator Clock Selection"), so the IMU was powered 65 ms before. */
#define POWER_ON_S (-0.065)
/*
 * Optiboot 4.4 (the Uno's bootloader, which the Metro Mini ships; Arduino core
 * bootloaders/optiboot/optiboot.c) after an external reset: the 65 ms time-out
 * of the fuses' start-up setting (low fuse 0xFF: DS40002061 table 9-4), three
 * LED flashes of 2 x 62.5 ms (flash_led), a 1 s watchdog wait for a programmer
 * (WATCHDOG_1S: table 11-2, 128K cycles of the 128 kHz oscillator), then the
 * watchdog's reset, 65 ms again, and the sketch.
 */
#define OPTIBOOT_MS (65 + 6 * 62.5 + 1000 + 65)
#define MAX_BOOTLOADER_MS 10000.0
#define HOST_BAUD_MIN 300.0        /* the CP2104's range, data sheet sec. 6.1 */
#define HOST_BAUD_MAX 2000000.0
#define MAX_BAUD_ERROR_PCT 10.0
/* --stuck-sda: a due reset waits for the next MPU read byte this long at most (the
 * firmware reads the MPU every sample period, 5 ms at 200 Hz, while it runs). */
#define RESET_IN_READ_WAIT_S 0.02

/* ---------------------------------------------------------------- options */

typedef struct options {
	const char *elf;
	const char *link;
	const char *motion;
	motion_interp_t interp;
	double flex_mv;   /* < 0: not given, the ADC reads 0 V */
	double flex_lo_mv, flex_hi_mv; /* the op-amp's output swing */
	int no_imu;
	unsigned long long seed;
	int no_noise;
	int16_t eeprom_bias[3]; /* --eeprom-bias: a gyro bias record in EEPROM at power-up */
	int has_eeprom_bias;
	double seconds;   /* <= 0: run until killed */
	double speed;     /* simulated seconds per wall second; 0: as fast as possible */
	int json;
	int verbose;
	double imu_startup_ms; /* the MPU's start-up time after power-on */
	double reset_at;  /* > 0: reset the AVR then (--stuck-sda: in the next MPU read byte) */
	int stuck_sda;    /* resets land in an MPU read byte, and the MPU holds SDA low */
	double glitch_at; /* > 0: the IMU's supply drops out and comes back then */
	int glitch_in_read; /* --glitch lands in an MPU read byte */
	double hang_at;   /* > 0: the CPU is sent into an endless loop then */
	int no_reset_on_open;
	double bootloader_ms;
	double host_baud;       /* 0: the rate the host set on the pty */
	double baud_error_pct;  /* the host end's clock error */
	double avr_baud_error_pct; /* the AVR end's (its resonator or crystal) */
} options_t;

static void usage(FILE *f)
{
	fprintf(f,
		"usage: boardsim ELF [--pty LINK] [--motion CSV] [--interp linear|hold]\n"
		"                [--flex-mv MV] [--flex-swing LO,HI] [--no-imu] [--seed N]\n"
		"                [--noise | --no-noise] [--eeprom-bias X,Y,Z] [--seconds S]\n"
		"                [--speed X] [--reset-on-open | --no-reset-on-open]\n"
		"                [--bootloader-ms MS] [--host-baud B] [--baud-error HOST[,AVR]]\n"
		"                [--json] [--verbose] [faults]\n"
		"Runs the firmware ELF on a simulated ATmega328P at 16 MHz with a virtual\n"
		"MPU-9250/AK8963 on I2C, a flex voltage on A0 and UART0 on a pty.\n"
		"  --pty LINK      make LINK a symlink to the UART's pty (open it at the sketch's rate)\n"
		"  --motion CSV    t,gx,gy,gz,ax,ay,az[,mx,my,mz][,flex_mv] (s, rad/s, m/s^2, uT, mV);\n"
		"                  default: lying still, gravity on +z\n"
		"  --interp MODE   linear (default) or hold, between CSV rows\n"
		"  --flex-mv MV    voltage on A0 in millivolts, 0..5000 (default 0)\n"
		"  --flex-swing LO,HI  the flex op-amp's output limits in millivolts (default\n"
		"                  0,5000: rail to rail); A0 never reads outside them\n"
		"  --no-imu        nothing answers on the I2C bus\n"
		"  --seed N        seed of the sensors' noise and offsets and of the garbling of\n"
		"                  bytes a receiver cannot read (default 1)\n"
		"  --noise         the data sheets' noise, zero-rate offsets and the gyroscope's\n"
		"                  start-up transient (the default)\n"
		"  --no-noise      ideal sensors: no noise, zero-rate offset or start-up transient\n"
		"  --eeprom-bias X,Y,Z  a saved gyro bias (counts) in EEPROM at power-up\n"
		"  --seconds S     run S simulated seconds (at most 1e6), then exit (default:\n"
		"                  until killed)\n"
		"  --speed X       simulated seconds per wall second, 0 or at least 0.001\n"
		"                  (default 1 with --pty, else 0 = as fast as possible)\n"
		"  --reset-on-open the host opening the pty resets the board, and the bootloader\n"
		"                  runs first, as on a Metro Mini (the default)\n"
		"  --no-reset-on-open  the host opening the pty does not reset the board\n"
		"  --bootloader-ms MS  the bootloader's time after a reset, 0..10000\n"
		"                  (default 1505: Optiboot's)\n"
		"  --host-baud B   the rate the host's bridge is asked for, 300..2000000\n"
		"                  (default: what the host set on the pty)\n"
		"  --baud-error HOST[,AVR]  each end's clock error in percent, -10..10 (default 0):\n"
		"                  the host's bridge, and the AVR's resonator as its UART sees it\n"
		"  --json          print a JSON report on stdout at the end\n"
		"  --verbose       show simavr's own messages\n"
		"faults (firmware/sim/README.md):\n"
		"  --imu-startup-ms MS  the MPU answers MS ms after power-on, 0..1000 (default 100,\n"
		"                  the data sheet's maximum)\n"
		"  --reset-at S    reset the AVR at S seconds (the sketch restarts at once; a host's\n"
		"                  open adds the bootloader's time); a reset in an MPU read leaves\n"
		"                  the MPU holding SDA low\n"
		"  --stuck-sda     the host's open and --reset-at reset the AVR in the middle of an\n"
		"                  MPU read byte, so the MPU holds SDA low (the worst moment)\n"
		"  --glitch T      the IMU's supply drops out at T seconds: registers to reset values\n"
		"  --glitch-in-read  --glitch lands in the next MPU read byte (the worst moment: the\n"
		"                  read that sees it comes before the MPU has started up again)\n"
		"  --hang-at S     the CPU falls into an endless loop at S (only a watchdog gets out)\n");
}

static int parse_double(const char *s, double *out)
{
	char *end;
	errno = 0;
	double v = strtod(s, &end);
	if (*s == '\0' || *end != '\0' || errno || !isfinite(v))
		return -1;
	*out = v;
	return 0;
}

/* "A" or "A,B": how many numbers were read (1 or 2; *b untouched with 1), -1 if not numbers. */
static int parse_pair(const char *s, double *a, double *b)
{
	char buf[64];
	const char *comma = strchr(s, ',');
	size_t n = comma ? (size_t)(comma - s) : strlen(s);
	if (n >= sizeof(buf))
		return -1;
	memcpy(buf, s, n);
	buf[n] = '\0';
	if (parse_double(buf, a) < 0 || (comma && parse_double(comma + 1, b) < 0))
		return -1;
	return comma ? 2 : 1;
}

/* "LO,HI" millivolts with 0 <= LO < HI <= VCC. */
static int parse_swing(const char *s, double *lo, double *hi)
{
	if (parse_pair(s, lo, hi) != 2)
		return -1;
	return *lo >= 0 && *lo < *hi && *hi <= VCC_MV ? 0 : -1;
}

/* "HOST[,AVR]": each end's clock error in percent, -10..10; AVR 0 if not given. */
static int parse_baud_errors(const char *s, double *host, double *avr)
{
	*avr = 0.0;
	if (parse_pair(s, host, avr) < 0)
		return -1;
	return fabs(*host) <= MAX_BAUD_ERROR_PCT && fabs(*avr) <= MAX_BAUD_ERROR_PCT ? 0 : -1;
}

static void die_usage(const char *fmt, const char *arg)
{
	fprintf(stderr, "boardsim: ");
	fprintf(stderr, fmt, arg);
	fprintf(stderr, " (boardsim --help shows the options)\n");
	exit(2);
}

/* A fault's time: simulated seconds above 0 and up to MAX_SECONDS. */
static void parse_fault_time(const char *name, const char *arg, double *out)
{
	if (parse_double(arg, out) < 0 || *out <= 0 || *out > MAX_SECONDS) {
		fprintf(stderr, "boardsim: %s takes a time in seconds above 0 and up to 1e6, not '%s' "
			"(boardsim --help shows the options)\n", name, arg);
		exit(2);
	}
}

static void parse_options(int argc, char **argv, options_t *o)
{
	static const struct option longopts[] = {
		{ "pty", required_argument, 0, 'p' },
		{ "motion", required_argument, 0, 'm' },
		{ "interp", required_argument, 0, 'i' },
		{ "flex-mv", required_argument, 0, 'f' },
		{ "no-imu", no_argument, 0, 'n' },
		{ "flex-swing", required_argument, 0, 'w' },
		{ "seed", required_argument, 0, 'S' },
		{ "no-noise", no_argument, 0, 'q' },
		{ "noise", no_argument, 0, 'N' },
		{ "eeprom-bias", required_argument, 0, 'e' },
		{ "seconds", required_argument, 0, 's' },
		{ "speed", required_argument, 0, 'x' },
		{ "json", no_argument, 0, 'j' },
		{ "verbose", no_argument, 0, 'v' },
		{ "help", no_argument, 0, 'h' },
		{ "imu-startup-ms", required_argument, 0, 'u' },
		{ "reset-at", required_argument, 0, 'r' },
		{ "glitch", required_argument, 0, 'g' },
		{ "stuck-sda", no_argument, 0, 'D' },
		{ "glitch-in-read", no_argument, 0, 'G' },
		{ "hang-at", required_argument, 0, 'H' },
		{ "no-reset-on-open", no_argument, 0, 'R' },
		{ "reset-on-open", no_argument, 0, 'O' },
		{ "bootloader-ms", required_argument, 0, 'B' },
		{ "host-baud", required_argument, 0, 'b' },
		{ "baud-error", required_argument, 0, 'E' },
		{ 0, 0, 0, 0 },
	};
	memset(o, 0, sizeof(*o));
	o->flex_mv = -1.0;
	o->flex_hi_mv = VCC_MV;
	o->seed = 1;
	o->speed = -1.0;
	o->imu_startup_ms = IMU_STARTUP_MAX_S * 1000.0;
	o->bootloader_ms = OPTIBOOT_MS;
	int c;
	while ((c = getopt_long(argc, argv, "h", longopts, NULL)) != -1) {
		switch (c) {
		case 'p': o->link = optarg; break;
		case 'm': o->motion = optarg; break;
		case 'n': o->no_imu = 1; break;
		case 'q': o->no_noise = 1; break;
		case 'N': o->no_noise = 0; break;
		case 'e': {
			int x, y, z;
			char end;
			if (sscanf(optarg, "%d,%d,%d%c", &x, &y, &z, &end) != 3 || x < INT16_MIN || x > INT16_MAX ||
			    y < INT16_MIN || y > INT16_MAX || z < INT16_MIN || z > INT16_MAX)
				die_usage("--eeprom-bias takes three counts X,Y,Z in -32768..32767, not '%s'", optarg);
			o->eeprom_bias[0] = (int16_t)x;
			o->eeprom_bias[1] = (int16_t)y;
			o->eeprom_bias[2] = (int16_t)z;
			o->has_eeprom_bias = 1;
			break;
		}
		case 'w':
			if (parse_swing(optarg, &o->flex_lo_mv, &o->flex_hi_mv) < 0)
				die_usage("--flex-swing takes LO,HI millivolts with 0 <= LO < HI <= 5000, not '%s'",
					  optarg);
			break;
		case 'S': {
			char *end;
			errno = 0;
			o->seed = strtoull(optarg, &end, 10);
			if (!isdigit((unsigned char)*optarg) || *end != '\0' || errno)
				die_usage("--seed takes a whole number 0..18446744073709551615, not '%s'", optarg);
			break;
		}
		case 'j': o->json = 1; break;
		case 'v': o->verbose = 1; break;
		case 'h': usage(stdout); exit(0);
		case 'i':
			if (strcmp(optarg, "linear") == 0)
				o->interp = MOTION_LINEAR;
			else if (strcmp(optarg, "hold") == 0)
				o->interp = MOTION_HOLD;
			else
				die_usage("--interp takes linear or hold, not '%s'", optarg);
			break;
		case 'f':
			if (parse_double(optarg, &o->flex_mv) < 0 || o->flex_mv < 0 || o->flex_mv > VCC_MV)
				die_usage("--flex-mv takes millivolts 0..5000, not '%s'", optarg);
			break;
		case 's':
			if (parse_double(optarg, &o->seconds) < 0 || o->seconds <= 0 ||
			    o->seconds > MAX_SECONDS)
				die_usage("--seconds takes a number of seconds above 0 and up to 1e6, not '%s'",
					  optarg);
			break;
		case 'x':
			if (parse_double(optarg, &o->speed) < 0 || o->speed < 0 ||
			    (o->speed > 0 && o->speed < MIN_SPEED))
				die_usage("--speed takes 0 (as fast as possible) or a number >= 0.001, not '%s'",
					  optarg);
			break;
		case 'u':
			if (parse_double(optarg, &o->imu_startup_ms) < 0 || o->imu_startup_ms < 0 ||
			    o->imu_startup_ms > 1000)
				die_usage("--imu-startup-ms takes milliseconds 0..1000, not '%s'", optarg);
			break;
		case 'r': parse_fault_time("--reset-at", optarg, &o->reset_at); break;
		case 'g': parse_fault_time("--glitch", optarg, &o->glitch_at); break;
		case 'D': o->stuck_sda = 1; break;
		case 'G': o->glitch_in_read = 1; break;
		case 'H': parse_fault_time("--hang-at", optarg, &o->hang_at); break;
		case 'R': o->no_reset_on_open = 1; break;
		case 'O': o->no_reset_on_open = 0; break;
		case 'B':
			if (parse_double(optarg, &o->bootloader_ms) < 0 || o->bootloader_ms < 0 ||
			    o->bootloader_ms > MAX_BOOTLOADER_MS)
				die_usage("--bootloader-ms takes milliseconds 0..10000, not '%s'", optarg);
			break;
		case 'b':
			if (parse_double(optarg, &o->host_baud) < 0 || o->host_baud < HOST_BAUD_MIN ||
			    o->host_baud > HOST_BAUD_MAX)
				die_usage("--host-baud takes a baud rate 300..2000000 (the CP2104's range), not '%s'",
					  optarg);
			break;
		case 'E':
			if (parse_baud_errors(optarg, &o->baud_error_pct, &o->avr_baud_error_pct) < 0)
				die_usage("--baud-error takes HOST[,AVR]: percentages -10..10, not '%s'", optarg);
			break;
		default: usage(stderr); exit(2);
		}
	}
	if (optind != argc - 1)
		die_usage("%s", optind >= argc ? "give the firmware ELF file" : "give exactly one ELF file");
	o->elf = argv[optind];
	if (o->speed < 0)
		o->speed = o->link ? 1.0 : 0.0;
}

/* ---------------------------------------------------------------- board state */

/* A reset due: the sketch restarts at once (--reset-at), or after the bootloader (DTR). */
typedef enum { RESET_NONE, RESET_PLAIN, RESET_BOOT } reset_kind_t;

typedef struct board {
	avr_t *avr;
	options_t opt;
	motion_t motion;
	imu_t imu;
	phases_t phases;
	frame_counter_t uart;
	uint64_t bytes_lost;      /* UART bytes the pty bridge had no room for */
	int host_stalled;         /* the host stopped reading the pty */
	uart_pty_t pty;
	int has_pty;
	/* the serial line and the host's end of it */
	host_port_t host;
	pthread_mutex_t host_lock; /* the host's bytes come on the pty part's thread */
	int reset_pending;        /* DTR rose: the AVR is held in reset until the main loop restarts it */
	avr_irq_t *uart_in;       /* bytes into UART0's receiver */
	double host_baud;         /* the host's requested rate, as last read */
	uint64_t boot_until;      /* the sketch starts at this cycle after a reset */
	uint64_t dtr_resets, bytes_to_bootloader, bytes_unheard, rx_garbled, tx_garbled;
	uint64_t rng;
	/* I2C */
	avr_irq_t *twi_in;
	i2cbus_t bus;             /* timing, SDA held, bus clear, pull-ups */
	int i2c_target;           /* 7-bit address being talked to, -1 none */
	int i2c_reading;          /* the target was addressed for a read */
	reset_kind_t fault_reset_pending; /* reset after this instruction */
	reset_kind_t reset_in_read;       /* --stuck-sda: a reset due at the next MPU read byte */
	double reset_in_read_by;          /* or at this simulated time at the latest */
	int glitch_in_read;               /* --glitch-in-read: a drop-out due at the next MPU read byte */
	double glitch_in_read_by;         /* or at this simulated time at the latest */
	uint64_t resets;          /* AVR resets after power-on (DTR, --reset-at, watchdog) */
	recovery_t recovery;      /* each fault and the first good sample after it */
	double read_start_s;      /* the newest read phase (D8) began then */
	double handed_read_s;     /* the sample last handed to Serial (D10) was read then */
	unsigned long long opens_seen;
	int i2c_busy;
	uint64_t i2c_busy_since;
	uint64_t i2c_bus_cycles;  /* simulated bus time, cycles */
	uint64_t i2c_transactions, i2c_nacks, i2c_bytes;
	/* ADC */
	avr_irq_t *adc0;
} board_t;

static volatile sig_atomic_t stop_signal;

static void on_signal(int sig)
{
	stop_signal = sig;
}

static double sim_seconds(const board_t *b)
{
	return (double)b->avr->cycle / F_CPU;
}

/* ---------------------------------------------------------------- I2C bus */

static int i2c_present(board_t *b, uint8_t addr7)
{
	if (b->opt.no_imu || i2cbus_blocked(&b->bus) || !imu_mpu_ready(&b->imu, sim_seconds(b)))
		return 0;
	if (addr7 == MPU_ADDR)
		return 1;
	return addr7 == AK_ADDR && imu_ak_reachable(&b->imu);
}

static void i2c_reply(board_t *b, uint8_t msg, uint8_t addr8, uint8_t data)
{
	avr_raise_irq(b->twi_in, avr_twi_irq_msg(msg, addr8, data));
}

/* The address phase of a transaction (a START or repeated START). */
static void i2c_address(board_t *b, uint8_t addr8)
{
	uint8_t addr7 = addr8 >> 1;
	b->i2c_transactions++;
	if (!i2c_present(b, addr7)) {
		b->i2c_target = -1;
		b->i2c_nacks++; /* nobody answers: the master sees a NACK */
		return;
	}
	b->i2c_target = addr7;
	b->i2c_reading = addr8 & 1;
	imu_start(&b->imu, addr7, addr8 & 1, sim_seconds(b));
	i2c_reply(b, TWI_COND_ACK, addr8, 1);
}

/* The IMU's supply drops out now (--glitch): every register to its reset value, and
 * the start-up time again. */
static void glitch_now(board_t *b, double now)
{
	b->glitch_in_read = 0;
	recovery_event(&b->recovery, "glitch", now, 1);
	imu_power_on(&b->imu, now);
}

/* Every message the TWI master puts on the bus. */
static void i2c_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq;
	board_t *b = param;
	avr_twi_msg_irq_t m;
	m.u.v = value;
	uint8_t msg = m.u.twi.msg;

	if (msg & (TWI_COND_START | TWI_COND_WRITE | TWI_COND_READ)) {
		b->i2c_busy = 1; /* until the TWI sets its next status */
		b->i2c_busy_since = b->avr->cycle;
		b->i2c_bytes++;
		i2cbus_byte(&b->bus);
	}
	if (msg & TWI_COND_STOP) {
		b->i2c_target = -1;
		return;
	}
	if (msg & TWI_COND_START) {
		i2c_address(b, m.u.twi.addr);
		return;
	}
	if (b->i2c_target < 0)
		return;
	if (msg & TWI_COND_WRITE) {
		imu_write(&b->imu, (uint8_t)b->i2c_target, m.u.twi.data);
		i2c_reply(b, TWI_COND_ACK, m.u.twi.addr, 1);
	} else if (msg & TWI_COND_READ) {
		if (b->reset_in_read && b->i2c_target == MPU_ADDR) {
			b->fault_reset_pending = b->reset_in_read; /* the MPU is sending: on_avr_reset */
			b->reset_in_read = RESET_NONE;
		}
		if (b->glitch_in_read && b->i2c_target == MPU_ADDR)
			glitch_now(b, sim_seconds(b)); /* this byte and the rest come from reset registers */
		uint8_t v = imu_read(&b->imu, (uint8_t)b->i2c_target);
		i2c_reply(b, TWI_COND_READ, m.u.twi.addr, v);
	}
}

/* The TWI set a status: the bus operation in flight has finished. */
static void i2c_status_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq;
	(void)value;
	board_t *b = param;
	if (b->i2c_busy) {
		b->i2c_bus_cycles += b->avr->cycle - b->i2c_busy_since;
		b->i2c_busy = 0;
	}
}

/* Every AVR reset: a slave in the middle of sending keeps SDA low (i2cbus.h). */
static void on_avr_reset(void *param)
{
	board_t *b = param;
	if (b->i2c_target == MPU_ADDR && b->i2c_reading)
		i2cbus_hold_sda(&b->bus);
	b->i2c_target = -1;
	b->i2c_busy = 0;
	b->resets++;
	recovery_restart(&b->recovery);
	for (int i = 0; i < PHASE_COUNT; i++)
		b->phases.p[i].high = 0; /* the reset cleared PORTB; an open phase is not counted */
}

static void attach_i2c(board_t *b)
{
	imu_init(&b->imu, &b->motion, b->opt.imu_startup_ms / 1000.0, b->opt.seed, !b->opt.no_noise);
	imu_power_on(&b->imu, POWER_ON_S);
	b->i2c_target = -1;
	if (i2cbus_attach(&b->bus, b->avr, on_avr_reset, b) < 0) {
		fprintf(stderr, "boardsim: this simavr has no TWI or port C on the %s\n", MCU);
		exit(1);
	}
	b->twi_in = avr_io_getirq(b->avr, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_INPUT);
	avr_irq_t *out = avr_io_getirq(b->avr, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_OUTPUT);
	avr_irq_t *status = avr_io_getirq(b->avr, AVR_IOCTL_TWI_GETIRQ(0), TWI_IRQ_STATUS);
	if (!b->twi_in || !out || !status) {
		fprintf(stderr, "boardsim: this simavr has no TWI on the %s\n", MCU);
		exit(1);
	}
	avr_irq_register_notify(out, i2c_hook, b);
	avr_irq_register_notify(status, i2c_status_hook, b);
}

/* ---------------------------------------------------------------- ADC */

/* The flex op-amp's output now, within its swing (--flex-swing), millivolts. */
static uint32_t flex_now(board_t *b)
{
	truth_t tr;
	motion_at(&b->motion, sim_seconds(b), &tr);
	double mv = tr.flex_mv >= 0 ? tr.flex_mv : b->opt.flex_mv >= 0 ? b->opt.flex_mv : 0.0;
	mv = fmin(fmax(mv, b->opt.flex_lo_mv), b->opt.flex_hi_mv);
	return (uint32_t)lround(mv);
}

/* A conversion starts: put the present flex voltage on ADC0 (millivolts). */
static void adc_trigger_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq;
	(void)value;
	board_t *b = param;
	avr_raise_irq(b->adc0, flex_now(b));
}

static void attach_adc(board_t *b)
{
	b->avr->vcc = b->avr->avcc = b->avr->aref = VCC_MV;
	b->adc0 = avr_io_getirq(b->avr, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_ADC0);
	avr_irq_t *trig = avr_io_getirq(b->avr, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_OUT_TRIGGER);
	avr_raise_irq(b->adc0, flex_now(b));
	avr_irq_register_notify(trig, adc_trigger_hook, b);
}

/* ---------------------------------------------------------------- phase pins */

static void pin_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
	board_t *b = param;
	int pin = (int)irq->irq; /* IOPORT_IRQ_PIN0 + n */
	if (pin < 0 || pin >= PHASE_COUNT)
		return;
	phases_edge(&b->phases.p[pin], (int)value, b->avr->cycle, b->i2c_bus_cycles);
	if (value && pin == PHASE_READ)
		b->read_start_s = sim_seconds(b);
	if (value && pin == PHASE_SEND)
		b->handed_read_s = b->read_start_s; /* recovery.h: the sample just read */
}

static void attach_pins(board_t *b)
{
	phases_init(&b->phases);
	for (int i = 0; i < PHASE_COUNT; i++) {
		avr_irq_t *irq = avr_io_getirq(b->avr, AVR_IOCTL_IOPORT_GETIRQ('B'), IOPORT_IRQ_PIN0 + i);
		avr_irq_register_notify(irq, pin_hook, b);
	}
}

/* ---------------------------------------------------------------- UART and pty */

/* ---------------------------------------------------------------- the serial line */

#define UCSR0A_ADDR 0xC0 /* DS40002061 sec. 20.11: UCSR0A (U2X0 is bit 1), UBRR0L, UBRR0H */
#define U2X0_BIT 1
#define UBRR0L_ADDR 0xC4
#define UBRR0H_ADDR 0xC5

/* UART0's rate as the firmware set it up. */
static double avr_baud(const board_t *b)
{
	const uint8_t *d = b->avr->data;
	unsigned ubrr = (unsigned)(d[UBRR0H_ADDR] & 0x0F) << 8 | d[UBRR0L_ADDR];
	return avr_uart_baud(F_CPU, ubrr, d[UCSR0A_ADDR] >> U2X0_BIT & 1) *
	       (1.0 + b->opt.avr_baud_error_pct / 100.0);
}

/* The rate on the wire from the host's bridge; 0 while unknown. */
static double host_line_baud(const board_t *b)
{
	double requested = b->opt.host_baud > 0 ? b->opt.host_baud : b->host_baud;
	if (requested <= 0)
		return 0.0;
	return cp2104_baud(requested) * (1.0 + b->opt.baud_error_pct / 100.0);
}

/* Whether the AVR reads the host's bytes (sec. 20.8.3) or the bridge the AVR's (CP2104 sec. 6.1). */
static int receiver_reads(const board_t *b, int to_avr)
{
	double host = host_line_baud(b);
	if (host <= 0)
		return 1;
	double avr = avr_baud(b);
	if (to_avr)
		return fabs(baud_mismatch_pct(host, avr)) <=
		       avr_rx_tolerance_pct(b->avr->data[UCSR0A_ADDR] >> U2X0_BIT & 1);
	return fabs(baud_mismatch_pct(avr, host)) <= CP2104_RX_TOLERANCE_PCT;
}

static int in_bootloader(const board_t *b)
{
	return b->avr->cycle < b->boot_until;
}

/*
 * Take in the host's opens and closes (from either thread): an open that
 * raises DTR resets the AVR at once, before any byte the host sends after it.
 */
static int host_holds_reset(board_t *b)
{
	pthread_mutex_lock(&b->host_lock);
	if (host_port_poll(&b->host) && !b->opt.no_reset_on_open)
		b->reset_pending = 1;
	int pending = b->reset_pending;
	pthread_mutex_unlock(&b->host_lock);
	return pending;
}

/* A byte from the host: the bootloader takes it, or the UART reads it as the rates allow. */
static void host_byte_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq;
	board_t *b = param;
	uint8_t byte = (uint8_t)value;
	if (host_holds_reset(b) || in_bootloader(b)) {
		b->bytes_to_bootloader++; /* Optiboot reads it, the sketch never does */
		return;
	}
	if (!receiver_reads(b, 1)) {
		byte = garble_byte(&b->rng, byte);
		b->rx_garbled++;
	}
	avr_raise_irq(b->uart_in, byte);
}

/* DTR asserted: the auto-reset pulse. The AVR restarts (on_avr_reset sees it), silent
 * until the bootloader is done. */
static void reset_into_bootloader(board_t *b)
{
	avr_reset(b->avr); /* simavr keeps the cycle count and drops pending cycle timers, */
	/* the pty part's among them, which hands the host's bytes over; XON restarts it */
	avr_raise_irq(avr_io_getirq(b->avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON), 1);
	b->boot_until = b->avr->cycle + (uint64_t)llround(b->opt.bootloader_ms * (F_CPU / 1000.0));
	b->dtr_resets++;
	pthread_mutex_lock(&b->host_lock);
	b->reset_pending = 0;
	pthread_mutex_unlock(&b->host_lock);
}

/* A reset is due: at once, or with --stuck-sda in the next MPU read byte (i2c_hook). */
static void reset_due(board_t *b, reset_kind_t kind)
{
	if (!b->opt.stuck_sda) {
		b->fault_reset_pending = kind;
		return;
	}
	b->reset_in_read = kind;
	b->reset_in_read_by = sim_seconds(b) + RESET_IN_READ_WAIT_S;
}

/* What the host did to its end since the last simulated millisecond. */
static void watch_host(board_t *b)
{
	if (!b->has_pty)
		return;
	int holds_reset = host_holds_reset(b);
	if (b->host.opened != b->opens_seen) {
		b->opens_seen = b->host.opened;
		recovery_event(&b->recovery, "open", sim_seconds(b), 0);
	}
	if (holds_reset && b->fault_reset_pending != RESET_BOOT && b->reset_in_read != RESET_BOOT)
		reset_due(b, RESET_BOOT);
	b->host_baud = host_port_baud(&b->host);
}

/* The bootloader's time: no instruction of the sketch runs, simulated time (and its timers) go on. */
static void run_bootloader(board_t *b)
{
	uint64_t left = b->boot_until - b->avr->cycle;
	b->avr->cycle += left < PACE_CYCLES ? left : PACE_CYCLES;
	avr_cycle_timer_process(b->avr);
}

static void json_line(FILE *f, const board_t *b)
{
	fprintf(f, "  \"line\": {\"host_opens\": %llu, \"resets\": %llu, \"bytes_to_bootloader\": %llu, "
		"\"bytes_unheard\": %llu, \"rx_garbled\": %llu, \"tx_garbled\": %llu, "
		"\"avr_baud\": %.1f, \"host_baud\": %.1f},\n",
		b->host.opened, (unsigned long long)b->dtr_resets, (unsigned long long)b->bytes_to_bootloader,
		(unsigned long long)b->bytes_unheard, (unsigned long long)b->rx_garbled,
		(unsigned long long)b->tx_garbled, avr_baud(b), host_line_baud(b));
}

/* ---------------------------------------------------------------- UART and pty */

/* Every byte the firmware's UART0 sends: count it, pass it to the pty. */
static void uart_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq;
	board_t *b = param;
	int type = frames_feed(&b->uart, (uint8_t)value);
	if (type == EB_RAW || type == EB_FUSED)
		recovery_sample(&b->recovery, b->handed_read_s, sim_seconds(b));
	if (!b->has_pty)
		return;
	if (b->host.opens == 0) {
		b->bytes_unheard++; /* a closed port's bridge has its UART off (Linux cp210x) */
		return;
	}
	if (!receiver_reads(b, 0)) {
		value = garble_byte(&b->rng, (uint8_t)value);
		b->tx_garbled++;
	}
	if (uart_pty_fifo_isfull(&b->pty.pty.in)) {
		b->bytes_lost++; /* like a USB-serial bridge whose host is not reading */
		return;
	}
	avr_raise_irq(b->pty.irq + IRQ_UART_PTY_BYTE_IN, value);
}

static void uart_flags(board_t *b)
{
	uint32_t f = 0;
	avr_ioctl(b->avr, AVR_IOCTL_UART_GET_FLAGS('0'), &f);
	f &= ~(AVR_UART_FLAG_STDIO | AVR_UART_FLAG_POLL_SLEEP); /* binary; we pace ourselves */
	avr_ioctl(b->avr, AVR_IOCTL_UART_SET_FLAGS('0'), &f);
}

/* Point `link` at `target` atomically (a reader never sees it missing). */
static int make_link(const char *link, const char *target)
{
	char tmp[4096];
	snprintf(tmp, sizeof(tmp), "%s.new%d", link, (int)getpid());
	unlink(tmp);
	if (symlink(target, tmp) < 0 || rename(tmp, link) < 0) {
		fprintf(stderr, "boardsim: cannot make the link %s -> %s: %s\n", link, target,
			strerror(errno));
		unlink(tmp);
		return -1;
	}
	return 0;
}

/* Remove `link` if it still points to `target`. */
static void remove_link(const char *link, const char *target)
{
	char buf[4096];
	ssize_t n = readlink(link, buf, sizeof(buf) - 1);
	if (n < 0)
		return;
	buf[n] = '\0';
	if (strcmp(buf, target) == 0)
		unlink(link);
}

static void attach_uart(board_t *b)
{
	avr_irq_t *src = avr_io_getirq(b->avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT);
	uart_flags(b);
	if (b->opt.link) {
		uart_pty_init(b->avr, &b->pty);
		if (!b->pty.pty.s) {
			fprintf(stderr, "boardsim: could not open a pty\n");
			exit(1);
		}
		uart_pty_connect(&b->pty, '0');
		/* Route the UART's output through uart_hook (counting, overflow) instead,
		 * and the host's bytes through host_byte_hook (bootloader, baud rates). */
		avr_unconnect_irq(src, b->pty.irq + IRQ_UART_PTY_BYTE_IN);
		pthread_mutex_init(&b->host_lock, NULL);
		if (host_port_watch(&b->host, b->pty.pty.s, b->pty.pty.slavename) < 0)
			exit(1);
		b->uart_in = avr_io_getirq(b->avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
		avr_unconnect_irq(b->pty.irq + IRQ_UART_PTY_BYTE_OUT, b->uart_in);
		avr_irq_register_notify(b->pty.irq + IRQ_UART_PTY_BYTE_OUT, host_byte_hook, b);
		remove_link("/tmp/simavr-uart0", b->pty.pty.slavename); /* the part's own link */
		b->has_pty = 1;
		if (make_link(b->opt.link, b->pty.pty.slavename) < 0)
			exit(1);
		fprintf(stderr, "boardsim: UART0 on %s (link %s)\n", b->pty.pty.slavename, b->opt.link);
	}
	avr_irq_register_notify(src, uart_hook, b);
}

/* ---------------------------------------------------------------- loading */

/* A clear message if `path` is not an AVR ELF file; 0 if it looks like one. */
static int check_elf(const char *path)
{
	unsigned char h[20];
	int fd = open(path, O_RDONLY);
	if (fd < 0) {
		fprintf(stderr, "boardsim: cannot open firmware %s: %s (build it with `make -C firmware`)\n",
			path, strerror(errno));
		return -1;
	}
	ssize_t n = read(fd, h, sizeof(h));
	close(fd);
	if (n < (ssize_t)sizeof(h) || memcmp(h, "\177ELF", 4) != 0) {
		fprintf(stderr, "boardsim: %s is not an ELF file (give the .elf that avr-gcc linked)\n", path);
		return -1;
	}
	unsigned machine = h[5] == 2 ? (unsigned)(h[18] << 8 | h[19]) : (unsigned)(h[18] | h[19] << 8);
	if (machine != EM_AVR_MACHINE) {
		fprintf(stderr, "boardsim: %s is an ELF file for another processor (e_machine %u), "
			"not AVR\n", path, machine);
		return -1;
	}
	return 0;
}

static void no_sleep(struct avr_t *avr, avr_cycle_count_t how_long)
{
	(void)avr;
	(void)how_long; /* the run loop paces against the wall clock */
}

static avr_t *load_firmware(const char *path, int verbose)
{
	elf_firmware_t fw;
	memset(&fw, 0, sizeof(fw));
	if (check_elf(path) < 0)
		return NULL;
	if (elf_read_firmware(path, &fw) < 0 || fw.flashsize == 0) {
		fprintf(stderr, "boardsim: cannot load %s: no program in it\n", path);
		return NULL;
	}
	avr_t *avr = avr_make_mcu_by_name(MCU);
	if (!avr) {
		fprintf(stderr, "boardsim: this simavr does not know the %s\n", MCU);
		return NULL;
	}
	avr_init(avr);
	avr->log = verbose ? LOG_TRACE : LOG_ERROR;
	avr_load_firmware(avr, &fw);
	avr->frequency = F_CPU;
	avr->sleep = no_sleep;
	return avr;
}

/* ---------------------------------------------------------------- running */

static double wall_now(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return ts.tv_sec + ts.tv_nsec * 1e-9;
}

static void sleep_for(double s)
{
	if (s <= 0)
		return;
	struct timespec ts = { (time_t)s, (long)((s - (time_t)s) * 1e9) };
	nanosleep(&ts, NULL);
}

/*
 * Let the host drain the pty: while bytes pile up in the bridge, wait for
 * the host as long as it makes progress. A host that reads nothing for 50 ms
 * (or nobody at all) is given up on until the queue drains again; meanwhile
 * the bytes that find no room are lost and counted, as on a real USB bridge.
 */
static void wait_for_host(board_t *b)
{
	uart_pty_fifo_t *q = &b->pty.pty.in;
	unsigned fill = uart_pty_fifo_get_read_size(q);
	if (fill <= PTY_FIFO_HIGH / 2)
		b->host_stalled = 0;
	if (fill <= PTY_FIFO_HIGH || b->host_stalled)
		return;
	double deadline = wall_now() + 0.05;
	while (fill > PTY_FIFO_HIGH) {
		if (wall_now() > deadline) {
			b->host_stalled = 1;
			return;
		}
		sleep_for(0.0002);
		unsigned now = uart_pty_fifo_get_read_size(q);
		if (now < fill)
			deadline = wall_now() + 0.05; /* progress: keep waiting */
		fill = now;
	}
}

/* Keep simulated time at `speed` times wall time. */
static void pace(board_t *b, double wall_start)
{
	if (b->has_pty)
		wait_for_host(b);
	if (b->opt.speed > 0)
		sleep_for(wall_start + sim_seconds(b) / b->opt.speed - wall_now());
}

/* --hang-at: the CPU jumps to an `rjmp .-2` put in the last flash word (the
 * bootloader's, unused here), as after a corrupted return address: the code
 * never comes back, interrupts go on; only a watchdog reset gets out. */
static void hang_cpu(avr_t *avr)
{
	avr->flash[avr->flashend - 1] = 0xFF; /* 0xCFFF, little endian: rjmp to itself */
	avr->flash[avr->flashend] = 0xCF;
	avr->pc = avr->flashend - 1;
}

/* The faults due by now (once a simulated ms), and the pull-up count. */
static void step_faults(board_t *b)
{
	double now = sim_seconds(b);
	i2cbus_tick_ms(&b->bus);
	if (b->opt.reset_at > 0 && now >= b->opt.reset_at) {
		b->opt.reset_at = 0;
		recovery_event(&b->recovery, "reset", now, 1);
		reset_due(b, RESET_PLAIN);
	}
	if (b->reset_in_read && now >= b->reset_in_read_by) { /* no MPU read came */
		b->fault_reset_pending = b->reset_in_read;
		b->reset_in_read = RESET_NONE;
	}
	if (b->opt.glitch_at > 0 && now >= b->opt.glitch_at) {
		b->opt.glitch_at = 0;
		if (b->opt.glitch_in_read) {
			b->glitch_in_read = 1;
			b->glitch_in_read_by = now + RESET_IN_READ_WAIT_S;
		} else {
			glitch_now(b, now);
		}
	}
	if (b->glitch_in_read && now >= b->glitch_in_read_by) /* no MPU read came */
		glitch_now(b, now);
	if (b->opt.hang_at > 0 && now >= b->opt.hang_at) {
		b->opt.hang_at = 0;
		recovery_event(&b->recovery, "hang", now, 1);
		hang_cpu(b->avr);
	}
}

typedef enum { END_SECONDS, END_SIGNAL, END_DONE, END_CRASHED } end_t;

static end_t run(board_t *b, double wall_start)
{
	avr_t *avr = b->avr;
	uint64_t limit = b->opt.seconds > 0 ? (uint64_t)llround(b->opt.seconds * F_CPU) : UINT64_MAX;
	uint64_t next_pace = PACE_CYCLES;
	for (;;) {
		int state = cpu_Running;
		if (in_bootloader(b))
			run_bootloader(b);
		else
			state = avr_run(avr);
		if (state == cpu_Done)
			return END_DONE;
		if (state == cpu_Crashed)
			return END_CRASHED;
		if (b->fault_reset_pending) {
			reset_kind_t kind = b->fault_reset_pending;
			b->fault_reset_pending = RESET_NONE;
			if (kind == RESET_BOOT)
				reset_into_bootloader(b);
			else
				avr_reset(avr); /* on_avr_reset sees it */
		}
		if (avr->cycle >= limit)
			return END_SECONDS;
		if (avr->cycle >= next_pace) {
			next_pace = avr->cycle + PACE_CYCLES;
			if (stop_signal)
				return END_SIGNAL;
			step_faults(b);
			watch_host(b);
			pace(b, wall_start);
		}
	}
}

/* ---------------------------------------------------------------- report */

static void json_phase(FILE *f, const phase_t *p, int last)
{
	double mean = p->count ? (double)p->total / p->count : 0.0;
	double own = p->count ? (double)(p->total - p->bus_total) / p->count : 0.0;
	fprintf(f, "    \"%s\": {\"pin\": \"%s\", \"count\": %llu, \"total_cycles\": %llu, "
		"\"mean_cycles\": %.1f, \"max_cycles\": %llu, \"i2c_bus_cycles\": %llu, "
		"\"mean_cycles_without_i2c_bus\": %.1f}%s\n",
		p->name, p->pin, (unsigned long long)p->count, (unsigned long long)p->total, mean,
		(unsigned long long)p->max, (unsigned long long)p->bus_total, own, last ? "" : ",");
}

/* A JSON string literal of s (quotes, backslashes and control characters escaped). */
static void json_string(FILE *f, const char *s)
{
	fputc('"', f);
	for (; *s; s++) {
		unsigned char ch = (unsigned char)*s;
		if (ch == '"' || ch == '\\')
			fprintf(f, "\\%c", ch);
		else if (ch < 0x20)
			fprintf(f, "\\u%04x", ch);
		else
			fputc(ch, f);
	}
	fputc('"', f);
}

/* The virtual IMU's seed and offsets, and the gyroscope bias the firmware saved in
 * EEPROM (its own record format, eb_bias.h), or null. */
static void json_imu(FILE *f, const board_t *b)
{
	const noise_t *n = &b->imu.noise;
	fprintf(f, "  \"imu\": {\"seed\": %llu, \"noise\": %s, \"gyro_zro_dps\": [%.6f, %.6f, %.6f]},\n",
		(unsigned long long)n->seed, n->on ? "true" : "false", n->gyr_zro[0] * 180.0 / M_PI,
		n->gyr_zro[1] * 180.0 / M_PI, n->gyr_zro[2] * 180.0 / M_PI);
	uint8_t rec[EB_BIAS_RECORD_SIZE];
	memset(rec, 0xFF, sizeof(rec)); /* a blank EEPROM if the copy fails */
	avr_eeprom_desc_t d = { rec, 0, sizeof(rec) };
	avr_ioctl(b->avr, AVR_IOCTL_EEPROM_GET, &d); /* copies; simavr 1.6 returns -1 even then */
	int16_t bias[3];
	if (eb_bias_unpack(rec, bias))
		fprintf(f, "  \"eeprom_bias\": [%d, %d, %d],\n", bias[0], bias[1], bias[2]);
	else
		fprintf(f, "  \"eeprom_bias\": null,\n");
}

/* --eeprom-bias: the firmware's own record (eb_bias.h) at address 0, as a board that
 * saved a bias at an earlier boot has it. */
static void preload_eeprom(board_t *b)
{
	if (!b->opt.has_eeprom_bias)
		return;
	uint8_t rec[EB_BIAS_RECORD_SIZE];
	eb_bias_pack(rec, b->opt.eeprom_bias);
	avr_eeprom_desc_t d = { rec, 0, sizeof(rec) };
	avr_ioctl(b->avr, AVR_IOCTL_EEPROM_SET, &d);
}

static void print_json(FILE *f, const board_t *b, end_t end, double wall)
{
	static const char *const ends[] = { "seconds", "signal", "done", "crashed" };
	const frame_counter_t *u = &b->uart;
	uint64_t samples = u->by_type[EB_RAW] + u->by_type[EB_FUSED];
	uint64_t total = 0, bus = 0;
	for (int i = 0; i < PHASE_COUNT; i++) {
		total += b->phases.p[i].total;
		bus += b->phases.p[i].bus_total;
	}
	uint64_t other = u->frames - samples - u->by_type[EB_TEMP] - u->by_type[EB_HELLO] -
			 u->by_type[EB_ACK];
	fprintf(f, "{\n  \"elf\": ");
	json_string(f, b->opt.elf);
	fprintf(f, ",\n  \"end\": \"%s\",\n", ends[end]);
	fprintf(f, "  \"simulated_s\": %.6f,\n  \"cycles\": %llu,\n  \"frequency_hz\": %u,\n"
		"  \"wall_s\": %.3f,\n", sim_seconds(b), (unsigned long long)b->avr->cycle, F_CPU, wall);
	fprintf(f, "  \"uart\": {\"bytes\": %llu, \"frames\": %llu, \"crc_errors\": %llu, "
		"\"bytes_lost\": %llu, \"raw\": %llu, \"fused\": %llu, \"temp\": %llu, \"hello\": %llu, "
		"\"ack\": %llu, \"other\": %llu, \"hello_errors\": %u},\n",
		(unsigned long long)u->bytes, (unsigned long long)u->frames,
		(unsigned long long)u->crc_errors, (unsigned long long)b->bytes_lost,
		(unsigned long long)u->by_type[EB_RAW], (unsigned long long)u->by_type[EB_FUSED],
		(unsigned long long)u->by_type[EB_TEMP], (unsigned long long)u->by_type[EB_HELLO],
		(unsigned long long)u->by_type[EB_ACK], (unsigned long long)other, (unsigned)u->hello_errors);
	json_line(f, b);
	fprintf(f, "  \"i2c\": {\"transactions\": %llu, \"nacks\": %llu, \"bytes\": %llu, "
		"\"bus_cycles\": %llu, \"scl_hz\": %u, \"stuck\": %llu, \"cleared\": %llu, \"blocked\": %s, "
		"\"pullup_ms\": %llu},\n",
		(unsigned long long)b->i2c_transactions, (unsigned long long)b->i2c_nacks,
		(unsigned long long)b->i2c_bytes, (unsigned long long)b->i2c_bus_cycles, F_CPU / i2cbus_scl_cycles(b->avr),
		(unsigned long long)b->bus.stuck, (unsigned long long)b->bus.cleared,
		i2cbus_blocked(&b->bus) ? "true" : "false", (unsigned long long)b->bus.pullup_ms);
	fprintf(f, "  \"resets\": %llu,\n  \"recovery\": ", (unsigned long long)b->resets);
	recovery_json(f, &b->recovery);
	fprintf(f, ",\n");
	json_imu(f, b);
	fprintf(f, "  \"phases\": {\n");
	for (int i = 0; i < PHASE_COUNT; i++)
		json_phase(f, &b->phases.p[i], i == PHASE_COUNT - 1);
	fprintf(f, "  },\n  \"samples\": %llu,\n", (unsigned long long)samples);
	fprintf(f, "  \"cycles_per_sample\": %.1f,\n  \"cycles_per_sample_without_i2c_bus\": %.1f,\n",
		samples ? (double)total / samples : 0.0, samples ? (double)(total - bus) / samples : 0.0);
	fprintf(f, "  \"cpu_load\": %.4f\n}\n", b->avr->cycle ? (double)total / b->avr->cycle : 0.0);
	fflush(f);
}

/* ---------------------------------------------------------------- main */

/*
 * simavr and its parts print chatter on stdout; keep stdout for the JSON
 * report and send the rest to /dev/null (or stderr with --verbose).
 */
static FILE *claim_stdout(int verbose)
{
	int saved = dup(STDOUT_FILENO);
	int sink = verbose ? dup(STDERR_FILENO) : open("/dev/null", O_WRONLY);
	FILE *out = saved >= 0 ? fdopen(saved, "w") : NULL;
	if (!out || sink < 0) {
		fprintf(stderr, "boardsim: cannot set up stdout: %s\n", strerror(errno));
		exit(1);
	}
	fflush(stdout);
	dup2(sink, STDOUT_FILENO);
	close(sink);
	return out;
}

static void install_signals(void)
{
	struct sigaction sa;
	memset(&sa, 0, sizeof(sa));
	sa.sa_handler = on_signal;
	sigaction(SIGINT, &sa, NULL);
	sigaction(SIGTERM, &sa, NULL);
	sigaction(SIGHUP, &sa, NULL);
	signal(SIGPIPE, SIG_IGN);
}

static void load_motion(board_t *b)
{
	char err[1024];
	if (!b->opt.motion) {
		motion_still(&b->motion);
		return;
	}
	if (motion_load(&b->motion, b->opt.motion, err, sizeof(err)) < 0) {
		fprintf(stderr, "boardsim: %s\n", err);
		exit(2);
	}
	b->motion.interp = b->opt.interp;
}

int main(int argc, char **argv)
{
	static board_t board; /* large (the pty part's buffers); not on the stack */
	board_t *b = &board;
	parse_options(argc, argv, &b->opt);
	load_motion(b);
	FILE *out = claim_stdout(b->opt.verbose);
	b->avr = load_firmware(b->opt.elf, b->opt.verbose);
	if (!b->avr)
		return 2;
	frames_init(&b->uart);
	recovery_init(&b->recovery);
	b->rng = b->opt.seed ^ 0x9E3779B97F4A7C15ull;
	if (b->rng == 0)
		b->rng = 0x9E3779B97F4A7C15ull; /* xorshift stays at 0 from 0 */
	attach_i2c(b);
	attach_adc(b);
	attach_pins(b);
	attach_uart(b);
	preload_eeprom(b);
	install_signals();

	double wall_start = wall_now();
	end_t end = run(b, wall_start);
	double wall = wall_now() - wall_start;
	if (end == END_CRASHED)
		fprintf(stderr, "boardsim: the firmware crashed at %.6f s (cycle %llu)\n",
			sim_seconds(b), (unsigned long long)b->avr->cycle);
	if (b->opt.json)
		print_json(out, b, end, wall);
	if (b->has_pty)
		remove_link(b->opt.link, b->pty.pty.slavename);
	motion_free(&b->motion);
	return end == END_CRASHED ? 3 : 0;
}
