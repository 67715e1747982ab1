/*
 * host_port.c - the host's opens, closes and baud rate on the board's pty.
 * See host_port.h. Only <asm/termbits.h> (not <termios.h>) is included: its
 * termios2 carries the exact rate, non-standard ones too (BOTHER).
 */
#include "host_port.h"

#include <asm/termbits.h>
#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <sys/inotify.h>
#include <sys/ioctl.h>
#include <unistd.h>

/*
 * A USB serial port starts with HUPCL set (Linux's tty_std_termios), a pty
 * without it: give the pty the serial port's default, which a host may clear.
 */
static int hang_up_by_default(int master)
{
	struct termios2 t;
	if (ioctl(master, TCGETS2, &t) < 0)
		return -1;
	t.c_cflag |= HUPCL;
	return ioctl(master, TCSETS2, &t);
}

int host_port_watch(host_port_t *hp, int master, const char *slave)
{
	memset(hp, 0, sizeof(*hp));
	hp->master = master;
	if (hang_up_by_default(master) < 0) {
		fprintf(stderr, "boardsim: cannot set up the pty %s: %s\n", slave, strerror(errno));
		return -1;
	}
	hp->inotify_fd = inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
	if (hp->inotify_fd < 0 ||
	    inotify_add_watch(hp->inotify_fd, slave, IN_OPEN | IN_CLOSE) < 0) {
		fprintf(stderr, "boardsim: cannot watch %s for the host opening it: %s\n", slave,
			strerror(errno));
		return -1;
	}
	return 0;
}

/* HUPCL: the tty layer drops DTR when the last descriptor closes (termios(3)). */
static int hangs_up_on_close(const host_port_t *hp)
{
	struct termios2 t;
	return ioctl(hp->master, TCGETS2, &t) < 0 || (t.c_cflag & HUPCL);
}

static int take_event(host_port_t *hp, const struct inotify_event *ev)
{
	if (ev->mask & IN_OPEN) {
		int edge = !hp->dtr; /* opening a tty raises DTR (and RTS) */
		hp->dtr = 1;
		hp->opens++;
		hp->opened++;
		return edge;
	}
	if ((ev->mask & IN_CLOSE) && hp->opens > 0 && --hp->opens == 0 && hangs_up_on_close(hp))
		hp->dtr = 0;
	return 0;
}

int host_port_poll(host_port_t *hp)
{
	char buf[4096] __attribute__((aligned(__alignof__(struct inotify_event))));
	int edge = 0;
	ssize_t n;
	while ((n = read(hp->inotify_fd, buf, sizeof(buf))) > 0) {
		for (char *p = buf; p < buf + n;) {
			const struct inotify_event *ev = (const struct inotify_event *)p;
			edge |= take_event(hp, ev);
			p += sizeof(*ev) + ev->len;
		}
	}
	return edge;
}

double host_port_baud(const host_port_t *hp)
{
	struct termios2 t;
	if (ioctl(hp->master, TCGETS2, &t) < 0)
		return 0.0;
	return (double)t.c_ospeed;
}
