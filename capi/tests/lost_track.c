/* The C side of the ABI's bad-input contract, compiled as C (not C++) by
 * tests/c_abi.rs: every misuse returns an error code with a message, a
 * pose the odometry lost is dropped and counted, and nothing crashes.
 * Exits 0 when every check holds, else prints the first failure. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include <turnprint.h>

#include "check.h"

static void spoil_top_k(tp_options *o) { o->top_k = 0; }
static void spoil_drift_min_score(tp_options *o) { o->drift_min_score = -0.5; }
static void spoil_exclusion_turning(tp_options *o) { o->exclusion_turning = 0.0; }
static void spoil_max_verify(tp_options *o) { o->max_verify = 0; }
static void spoil_queue_capacity(tp_options *o) { o->queue_capacity = 0; }
static void spoil_jump_factor(tp_options *o) { o->jump_factor = 0.5; }
static void spoil_workers(tp_options *o) { o->workers = 0; }

int main(void) {
    tp_options options;
    CHECK(tp_options_default(NULL) == TP_ERROR);
    CHECK(tp_options_default(&options) == TP_ACCEPTED);
    CHECK(options.top_k >= 1 && options.min_score >= 0.0);

    options.min_score = 2.0;
    CHECK(tp_detector_new(&options) == NULL);
    CHECK(strstr(tp_last_error(), "min_score") != NULL);
    options.min_score = NAN;
    CHECK(tp_detector_new(&options) == NULL);

    /* Each setting out of its range is named in the error. */
    const struct {
        const char *name;
        void (*spoil)(tp_options *);
    } invalid[] = {
        {"top_k", spoil_top_k},
        {"drift_min_score", spoil_drift_min_score},
        {"exclusion_turning", spoil_exclusion_turning},
        {"max_verify", spoil_max_verify},
        {"queue_capacity", spoil_queue_capacity},
        {"jump_factor", spoil_jump_factor},
        {"workers", spoil_workers},
    };
    for (size_t i = 0; i < sizeof invalid / sizeof invalid[0]; ++i) {
        CHECK(tp_options_default(&options) == TP_ACCEPTED);
        invalid[i].spoil(&options);
        CHECK(tp_detector_new(&options) == NULL);
        CHECK(strstr(tp_last_error(), invalid[i].name) != NULL);
    }

    tp_detector *d = tp_detector_new(NULL);
    CHECK(d != NULL);
    tp_pose pose;
    memset(&pose, 0, sizeof pose);
    pose.has_time = 1;
    pose.keyframe = -1;
    CHECK(tp_detector_push(NULL, &pose) == TP_ERROR);
    CHECK(tp_detector_push(d, NULL) == TP_ERROR);

    /* A circle driven twice, with the odometry losing track now and then. */
    for (int i = 0; i < 2000; ++i) {
        double a = 2.0 * 3.14159265358979 * i / 700.0;
        pose.t = 0.1 * i;
        pose.position[0] = 50.0 * cos(a);
        pose.position[1] = 50.0 * sin(a) + 10.0 * sin(3.0 * a);
        pose.position[2] = 0.0;
        int expected = TP_ACCEPTED;
        if (i % 97 == 50) {
            pose.position[1] = NAN;
            expected = TP_REJECTED_NON_FINITE;
        }
        CHECK(tp_detector_push(d, &pose) == expected);
    }
    pose.t = 1.0; /* back in time */
    CHECK(tp_detector_push(d, &pose) == TP_REJECTED_OUT_OF_ORDER);
    pose.t = 0.1 * 1999; /* the last timestamp again */
    CHECK(tp_detector_push(d, &pose) == TP_REJECTED_DUPLICATE);

    CHECK(tp_detector_poll(NULL, NULL, 0) == TP_ERROR);
    CHECK(tp_detector_poll(d, NULL, 4) == TP_ERROR);
    CHECK(tp_detector_poll(d, NULL, 0) == 0);

    tp_summary summary;
    CHECK(tp_detector_finish(d, &summary) == TP_ACCEPTED);
    CHECK(summary.poses == 2002);
    CHECK(summary.non_finite == 21);
    CHECK(summary.out_of_order == 1 && summary.duplicate == 1 && summary.stamps_ahead == 0);
    CHECK(summary.accepted == 2002 - 23);
    CHECK(tp_detector_finish(d, &summary) == TP_ERROR);
    CHECK(tp_detector_push(d, &pose) == TP_ERROR);
    CHECK(strstr(tp_last_error(), "finished") != NULL);

    /* Every candidate the worker made is still there to poll. */
    tp_candidate c;
    uint64_t polled = 0;
    while (tp_detector_poll(d, &c, 1) == 1) {
        CHECK(c.score >= 0.0 && c.score <= 1.0);
        /* The query is the later part. The ranges may overlap: a stretch
         * longer than one lap of this circle matches the lap before. */
        CHECK(c.query_first <= c.query_last && c.match_first <= c.match_last);
        CHECK(c.match_first < c.query_first && c.match_last < c.query_last);
        ++polled;
    }
    CHECK(polled == summary.candidates);
    CHECK(polled > 0);

    tp_detector_free(d);
    tp_detector_free(NULL);
    printf("ok %llu candidates\n", (unsigned long long)polled);
    return 0;
}
