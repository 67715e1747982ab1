/*
 * i2cbus.c - bit timing, a slave holding SDA, GPIO bus clear and pull-ups (see i2cbus.h).
 */
#include "i2cbus.h"

#include <string.h>

#include <avr_ioport.h>
#include <avr_twi.h>
#include <sim_cycle_timers.h>

/* Data-space addresses (DS40002061, register summary). */
#define PINC_ADDR 0x26
#define DDRC_ADDR 0x27
#define PORTC_ADDR 0x28
#define TWBR_ADDR 0xB8
#define TWSR_ADDR 0xB9
#define TWCR_ADDR 0xBC
#define TWEN_BIT 0x04
#define SDA_BIT 0x10 /* PC4 */
#define SCL_BIT 0x20 /* PC5 */
#define TWI_BYTE_CLOCKS 9 /* eight bits and the acknowledge */

uint32_t i2cbus_scl_cycles(const avr_t *avr)
{
	uint32_t prescaler = 1u << (2 * (avr->data[TWSR_ADDR] & 3)); /* 4^TWPS */
	return 16u + 2u * avr->data[TWBR_ADDR] * prescaler;
}

/* ------------------------------------------------------------ bit timing */

/* One cycle after a byte started, simavr has set its completion timer: move it. */
static avr_cycle_count_t retime_byte(avr_t *avr, avr_cycle_count_t when, void *param)
{
	(void)when;
	i2cbus_t *bus = param;
	for (avr_cycle_timer_slot_p t = avr->cycle_timers.timer; t; t = t->next) {
		if (t->param != bus->twi)
			continue;
		avr_cycle_timer_t done = t->timer;
		uint64_t end = bus->byte_start + (uint64_t)TWI_BYTE_CLOCKS * i2cbus_scl_cycles(avr);
		avr_cycle_timer_cancel(avr, done, bus->twi);
		avr_cycle_timer_register(avr, end > avr->cycle ? end - avr->cycle : 1, done, bus->twi);
		break;
	}
	return 0;
}

void i2cbus_byte(i2cbus_t *bus)
{
	bus->byte_start = bus->avr->cycle;
	avr_cycle_timer_register(bus->avr, 0, retime_byte, bus);
}

/* ------------------------------------------------------------ SDA held, bus clear */

void i2cbus_hold_sda(i2cbus_t *bus)
{
	bus->sda_held = 1;
	bus->awaiting_stop = 0;
	bus->clocks = 0;
	bus->stuck++;
}

int i2cbus_blocked(const i2cbus_t *bus)
{
	return bus->sda_held || bus->awaiting_stop;
}

static int twi_on(const avr_t *avr)
{
	return (avr->data[TWCR_ADDR] & TWEN_BIT) != 0;
}

/* An open-drain line: low while its pin drives (DDR = 1, PORT = 0), else pulled up. */
static int line_level(uint8_t ddr, uint8_t port, uint8_t bit)
{
	return !((ddr & bit) && !(port & bit));
}

/* Show the lines on PINC (for pins that are inputs, that is what a read returns). */
static void show_pins(i2cbus_t *bus)
{
	uint8_t *pin = &bus->avr->data[PINC_ADDR];
	*pin = (uint8_t)((*pin & ~(SDA_BIT | SCL_BIT)) | (bus->sda ? SDA_BIT : 0) |
			 (bus->scl ? SCL_BIT : 0));
}

/* New levels of the lines from the pins: count clocks, see the STOP. */
static void gpio_update(i2cbus_t *bus, uint8_t ddr, uint8_t port)
{
	if (twi_on(bus->avr))
		return; /* the TWI owns the pins */
	int scl = line_level(ddr, port, SCL_BIT);
	int sda = line_level(ddr, port, SDA_BIT) && !bus->sda_held;
	if (scl && !bus->scl && bus->sda_held && ++bus->clocks >= I2CBUS_RELEASE_CLOCKS) {
		bus->sda_held = 0; /* the rest of its byte and the acknowledge slot are clocked out */
		bus->awaiting_stop = 1;
		sda = line_level(ddr, port, SDA_BIT);
	}
	if (scl && bus->scl && sda && !bus->sda && bus->awaiting_stop) {
		bus->awaiting_stop = 0; /* STOP: SDA rises while SCL is high */
		bus->cleared++;
	}
	bus->scl = scl;
	bus->sda = sda;
	show_pins(bus);
}

/* DDRC is about to take `value` (simavr raises this before storing it). */
static void ddr_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq;
	i2cbus_t *bus = param;
	gpio_update(bus, (uint8_t)value, bus->avr->data[PORTC_ADDR]);
}

/* PORTC was written, or simavr changed a pin: recompute the lines (and PINC). */
static void port_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq;
	(void)value;
	i2cbus_t *bus = param;
	gpio_update(bus, bus->avr->data[DDRC_ADDR], bus->avr->data[PORTC_ADDR]);
}

void i2cbus_tick_ms(i2cbus_t *bus)
{
	const uint8_t *d = bus->avr->data;
	if (d[PORTC_ADDR] & ~d[DDRC_ADDR] & (SDA_BIT | SCL_BIT))
		bus->pullup_ms++;
}

/* ------------------------------------------------------------ attaching */

static void bus_reset(avr_io_t *io)
{
	i2cbus_t *bus = (i2cbus_t *)io; /* io is the first member */
	bus->scl = bus->sda = 1;
	if (bus->on_reset)
		bus->on_reset(bus->param);
}

static avr_io_t *find_io(avr_t *avr, const char *kind)
{
	for (avr_io_t *io = avr->io_port; io; io = io->next)
		if (io->kind && strcmp(io->kind, kind) == 0)
			return io;
	return NULL;
}

int i2cbus_attach(i2cbus_t *bus, avr_t *avr, void (*on_reset)(void *param), void *param)
{
	memset(bus, 0, sizeof(*bus));
	bus->avr = avr;
	bus->twi = find_io(avr, "twi");
	bus->on_reset = on_reset;
	bus->param = param;
	bus->scl = bus->sda = 1;
	bus->io.kind = "i2cbus";
	bus->io.reset = bus_reset;
	avr_register_io(avr, &bus->io);
	avr_irq_t *port = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('C'), 0);
	if (!bus->twi || !port)
		return -1;
	avr_irq_register_notify(port + IOPORT_IRQ_DIRECTION_ALL, ddr_hook, bus);
	avr_irq_register_notify(port + IOPORT_IRQ_REG_PORT, port_hook, bus);
	avr_irq_register_notify(port + IOPORT_IRQ_PIN4, port_hook, bus);
	avr_irq_register_notify(port + IOPORT_IRQ_PIN5, port_hook, bus);
	return 0;
}
