/*
 * host_port.h - what the host does with its end of the board's pty: opening
 * and closing it (the USB bridge's DTR line, and so the board's reset), and
 * the baud rate it set.
 *
 * simavr's uart_pty part keeps its own descriptor of the pty's slave open, so
 * poll() on the master never reports POLLHUP; instead an inotify watch on the
 * slave's device node sees every open and close by another process (Linux).
 */
#ifndef BOARDSIM_HOST_PORT_H
#define BOARDSIM_HOST_PORT_H

typedef struct host_port {
	int inotify_fd;
	int master;   /* the pty's master (the uart_pty part's) */
	int opens;    /* the host's open descriptions of the slave */
	int dtr;      /* the bridge's DTR line is asserted */
	unsigned long long opened; /* opens seen in all */
} host_port_t;

/* Start watching `slave` (the pty's device path); -1 with a message on stderr. */
int host_port_watch(host_port_t *hp, int master, const char *slave);

/*
 * Take in the host's opens and closes since the last call. Returns 1 when DTR
 * went from released to asserted: on the Metro Mini that edge, through a
 * 0.1 uF capacitor, pulls RESET low (Arduino's auto-reset circuit).
 */
int host_port_poll(host_port_t *hp);

/* The baud rate the host last set on its end (0 if it cannot be read). */
double host_port_baud(const host_port_t *hp);

#endif
