#include "eb_board.h"

#include "eb_budget.h"
#include "eb_sensors.h"

void eb_state_power_up(eb_state_t *s)
{
    s->rate_hz = EB_BOOT_RATE_HZ;
    s->mode = EB_MODE_RAW;
    s->streaming = true; /* a plain serial monitor sees data without a handshake */
    s->seq = 0;
    s->raw_sent = 0;
}

bool eb_temp_due(const eb_state_t *s)
{
    return s->raw_sent == 0 || s->raw_sent >= s->rate_hz;
}

void eb_count_raw(eb_state_t *s, bool after_temp)
{
    s->raw_sent = after_temp ? 1 : (uint16_t)(s->raw_sent + 1);
}

eb_reply_t eb_execute(eb_state_t *s, const eb_command_t *c)
{
    eb_reply_t r = {true, EB_ACK_OK, EB_ACTION_NONE, false};
    switch (c->type) {
    case EB_START:
        s->streaming = true;
        s->raw_sent = 0; /* a TEMP frame before the first RAW frame */
        break;
    case EB_STOP:
        s->streaming = false;
        break;
    case EB_SET_RATE:
        if (eb_rate_valid(c->arg, s->mode)) {
            s->rate_hz = c->arg;
            r.action = EB_ACTION_RETIME;
        } else {
            r.status = EB_ACK_BAD_ARGUMENT;
        }
        break;
    case EB_SET_MODE:
        /* a mode whose limit is below the present rate is refused: set the rate first */
        if ((c->arg == EB_MODE_RAW || c->arg == EB_MODE_FUSED) && eb_rate_valid(s->rate_hz, (uint8_t)c->arg)) {
            if (c->arg != s->mode) {
                r.action = EB_ACTION_MODE;
                s->raw_sent = 0; /* into RAW: a TEMP frame before the first RAW frame */
            }
            s->mode = (uint8_t)c->arg;
        } else {
            r.status = EB_ACK_BAD_ARGUMENT;
        }
        break;
    case EB_IDENTIFY:
        r.ack = false; /* HELLO, no ACK */
        r.hello = true;
        break;
    case EB_RESET:
        eb_state_power_up(s); /* ACK first, then power-up state, then HELLO */
        r.action = EB_ACTION_RESET;
        r.hello = true;
        break;
    default:
        r.ack = false; /* the parser passes commands only; nothing else is answered */
        break;
    }
    return r;
}

bool eb_rail_update(eb_rail_t *r, uint16_t adc, uint16_t rate_hz)
{
    uint16_t need = (uint16_t)(eb_flex_rail_seconds(adc) * rate_hz);
    if (!need)
        r->run = 0;
    else if (r->run < need)
        r->run++;
    return need && r->run >= need;
}

bool eb_led_on(uint8_t pattern, uint32_t ms)
{
    switch (pattern) {
    case EB_LED_CALIBRATING: return true;
    case EB_LED_STREAMING: return ms % 1000u < 50u;
    case EB_LED_IDLE: return ms % 2000u < 1000u;
    default: return ms % 200u < 100u;
    }
}
