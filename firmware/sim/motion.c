/*
 * motion.c - motion CSV loading and sampling (see motion.h).
 */
#include "motion.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Column indices into a row of values. */
enum { COL_T, COL_GX, COL_GY, COL_GZ, COL_AX, COL_AY, COL_AZ,
       COL_MX, COL_MY, COL_MZ, COL_FLEX, NCOLS };

static const char *const col_names[NCOLS] = {
	"t", "gx", "gy", "gz", "ax", "ay", "az", "mx", "my", "mz", "flex_mv",
};

#define MAX_FIELDS 32
#define MAX_LINE 4096

static void still_row(truth_t *r)
{
	memset(r, 0, sizeof(*r));
	r->acc[2] = MOTION_GRAVITY;
	r->mag[0] = MOTION_FIELD_X;
	r->mag[1] = MOTION_FIELD_Y;
	r->mag[2] = MOTION_FIELD_Z;
	r->flex_mv = -1.0;
}

void motion_still(motion_t *m)
{
	memset(m, 0, sizeof(*m));
	m->t = calloc(1, sizeof(double));
	m->rows = calloc(1, sizeof(truth_t));
	if (!m->t || !m->rows) {
		fprintf(stderr, "boardsim: out of memory\n");
		exit(1);
	}
	still_row(&m->rows[0]);
	m->n = 1;
}

void motion_free(motion_t *m)
{
	free(m->t);
	free(m->rows);
	memset(m, 0, sizeof(*m));
}

static void seterr(char *err, size_t errlen, const char *fmt, ...)
{
	va_list ap;
	va_start(ap, fmt);
	vsnprintf(err, errlen, fmt, ap);
	va_end(ap);
}

/* Trim spaces and a trailing CR/LF in place; returns the start. */
static char *trim(char *s)
{
	while (*s == ' ' || *s == '\t')
		s++;
	size_t n = strlen(s);
	while (n && (s[n - 1] == ' ' || s[n - 1] == '\t' || s[n - 1] == '\r' || s[n - 1] == '\n'))
		s[--n] = '\0';
	return s;
}

/* Split a line on commas in place; returns the number of fields. */
static int split(char *line, char *fields[], int max)
{
	int n = 0;
	char *p = line;
	for (;;) {
		char *comma = strchr(p, ',');
		if (n == max)
			return max + 1;
		if (comma)
			*comma = '\0';
		fields[n++] = trim(p);
		if (!comma)
			return n;
		p = comma + 1;
	}
}

/*
 * Map header fields to columns: colmap[field] = column or -1 (ignored).
 * Returns a bit mask of the columns present, or -1 on a duplicate.
 */
static int parse_header(char *fields[], int nf, int colmap[], char *err, size_t errlen)
{
	int present = 0;
	for (int f = 0; f < nf; f++) {
		colmap[f] = -1;
		for (int c = 0; c < NCOLS; c++) {
			if (strcmp(fields[f], col_names[c]) == 0) {
				if (present & (1 << c)) {
					seterr(err, errlen, "column '%s' appears twice in the header", col_names[c]);
					return -1;
				}
				colmap[f] = c;
				present |= 1 << c;
			}
		}
	}
	return present;
}

static int check_columns(int present, char *err, size_t errlen)
{
	for (int c = COL_T; c <= COL_AZ; c++) {
		if (!(present & (1 << c))) {
			seterr(err, errlen, "the header lacks column '%s' (need t,gx,gy,gz,ax,ay,az; "
			       "optional mx,my,mz and flex_mv)", col_names[c]);
			return -1;
		}
	}
	int mag = present & (7 << COL_MX);
	if (mag && mag != (7 << COL_MX)) {
		seterr(err, errlen, "give all of mx,my,mz or none of them");
		return -1;
	}
	return 0;
}

/* Parse one finite number; returns -1 if the text is not one. */
static int parse_number(const char *s, double *out)
{
	char *end;
	errno = 0;
	double v = strtod(s, &end);
	if (*s == '\0' || *end != '\0' || errno == ERANGE || !isfinite(v))
		return -1;
	*out = v;
	return 0;
}

/* Grow the row arrays to hold at least n + 1 rows. */
static int reserve(motion_t *m, size_t *cap)
{
	if (m->n < *cap)
		return 0;
	size_t ncap = *cap ? *cap * 2 : 256;
	double *t = realloc(m->t, ncap * sizeof(*t));
	if (t)
		m->t = t;
	truth_t *rows = realloc(m->rows, ncap * sizeof(*rows));
	if (rows)
		m->rows = rows;
	if (!t || !rows)
		return -1;
	*cap = ncap;
	return 0;
}

/* Parse one data row into m (appended). Returns -1 with a message on error. */
static int parse_row(motion_t *m, char *fields[], int nf, int nheader, const int colmap[],
		     int present, long lineno, char *err, size_t errlen)
{
	if (nf != nheader) {
		seterr(err, errlen, "line %ld has %d fields, the header has %d", lineno, nf, nheader);
		return -1;
	}
	double v[NCOLS] = { 0 };
	for (int f = 0; f < nf; f++) {
		if (colmap[f] < 0)
			continue;
		if (parse_number(fields[f], &v[colmap[f]]) < 0) {
			seterr(err, errlen, "line %ld: '%s' is not a finite number (column %s)",
			       lineno, fields[f], col_names[colmap[f]]);
			return -1;
		}
	}
	/* As --flex-mv: A0 sees 0..VCC (and a negative value would mean "not given"). */
	if ((present & (1 << COL_FLEX)) && (v[COL_FLEX] < 0 || v[COL_FLEX] > MOTION_VCC_MV)) {
		seterr(err, errlen, "line %ld: flex_mv = %g is outside 0..%u millivolts",
		       lineno, v[COL_FLEX], MOTION_VCC_MV);
		return -1;
	}
	if (m->n && v[COL_T] <= m->t[m->n - 1]) {
		seterr(err, errlen, "line %ld: t = %g does not increase (previous %g)",
		       lineno, v[COL_T], m->t[m->n - 1]);
		return -1;
	}
	truth_t *r = &m->rows[m->n];
	still_row(r);
	for (int i = 0; i < 3; i++) {
		r->gyr[i] = v[COL_GX + i];
		r->acc[i] = v[COL_AX + i];
		if (present & (1 << COL_MX))
			r->mag[i] = v[COL_MX + i];
	}
	if (present & (1 << COL_FLEX))
		r->flex_mv = v[COL_FLEX];
	m->t[m->n++] = v[COL_T];
	return 0;
}

static int load_stream(motion_t *m, FILE *f, char *err, size_t errlen)
{
	char line[MAX_LINE];
	char *fields[MAX_FIELDS + 1];
	int colmap[MAX_FIELDS + 1];
	int nheader = 0, present = 0;
	size_t cap = 0;
	long lineno = 0;

	while (fgets(line, sizeof(line), f)) {
		lineno++;
		if (!strchr(line, '\n') && !feof(f)) {
			seterr(err, errlen, "line %ld is longer than %d bytes", lineno, MAX_LINE - 1);
			return -1;
		}
		char *s = trim(line);
		if (*s == '\0' || *s == '#')
			continue;
		int nf = split(s, fields, MAX_FIELDS);
		if (nf > MAX_FIELDS) {
			seterr(err, errlen, "line %ld has more than %d fields", lineno, MAX_FIELDS);
			return -1;
		}
		if (!nheader) {
			present = parse_header(fields, nf, colmap, err, errlen);
			if (present < 0 || check_columns(present, err, errlen) < 0)
				return -1;
			nheader = nf;
			continue;
		}
		if (reserve(m, &cap) < 0) {
			seterr(err, errlen, "out of memory at line %ld", lineno);
			return -1;
		}
		if (parse_row(m, fields, nf, nheader, colmap, present, lineno, err, errlen) < 0)
			return -1;
	}
	if (ferror(f)) {
		seterr(err, errlen, "read error: %s", strerror(errno));
		return -1;
	}
	if (!nheader) {
		seterr(err, errlen, "empty file (expected a header t,gx,gy,gz,ax,ay,az)");
		return -1;
	}
	if (!m->n) {
		seterr(err, errlen, "no data rows after the header");
		return -1;
	}
	return 0;
}

int motion_load(motion_t *m, const char *path, char *err, size_t errlen)
{
	memset(m, 0, sizeof(*m));
	FILE *f = fopen(path, "r");
	if (!f) {
		seterr(err, errlen, "cannot open motion file %s: %s", path, strerror(errno));
		return -1;
	}
	char msg[512] = "";
	int rc = load_stream(m, f, msg, sizeof(msg));
	fclose(f);
	if (rc < 0) {
		seterr(err, errlen, "bad motion file %s: %s", path, msg);
		motion_free(m);
	}
	return rc;
}

/* Index of the last row with t[i] <= t (binary search); 0 if t is before all. */
static size_t row_before(const motion_t *m, double t)
{
	size_t lo = 0, hi = m->n;
	while (hi - lo > 1) {
		size_t mid = (lo + hi) / 2;
		if (m->t[mid] <= t)
			lo = mid;
		else
			hi = mid;
	}
	return lo;
}

static double lerp(double a, double b, double w)
{
	return a + (b - a) * w;
}

void motion_at(const motion_t *m, double t, truth_t *out)
{
	size_t i = row_before(m, t);
	const truth_t *a = &m->rows[i];
	if (m->interp == MOTION_HOLD || i + 1 >= m->n || t <= m->t[i]) {
		*out = *a;
		return;
	}
	const truth_t *b = &m->rows[i + 1];
	double w = (t - m->t[i]) / (m->t[i + 1] - m->t[i]);
	for (int k = 0; k < 3; k++) {
		out->gyr[k] = lerp(a->gyr[k], b->gyr[k], w);
		out->acc[k] = lerp(a->acc[k], b->acc[k], w);
		out->mag[k] = lerp(a->mag[k], b->mag[k], w);
	}
	out->flex_mv = a->flex_mv < 0 ? a->flex_mv : lerp(a->flex_mv, b->flex_mv, w);
}
