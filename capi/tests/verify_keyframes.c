/* The verifier sidecar from C, run by tests/c_abi.rs next to a real
 * `turnprint-verifier`:
 *
 *   verify_keyframes PREFIX WIDTH HEIGHT FRAME12.gray FRAME13.gray
 *
 * publishes two real KITTI 06 frames one step apart as keyframes 12 and 13,
 * submits the candidate 13 -> 12 (confirmed) and one naming a keyframe
 * never published (rejected), then prints "kill" and waits for a line on
 * stdin, after which the verifier is gone: a third candidate must expire.
 *
 *   verify_keyframes PREFIX absent
 *
 * no verifier runs on PREFIX: a candidate expires at once.
 * Exits 0 when every check holds, else prints the first failure. */
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <turnprint.h>

#include "check.h"

static void nap(void) {
    struct timespec ms10 = {0, 10 * 1000 * 1000};
    nanosleep(&ms10, NULL);
}

/* Polls until `n` verdicts arrived or 30 s passed; returns how many. */
static int collect(tp_verifier *v, tp_verdict *out, int n) {
    int got = 0;
    for (int i = 0; i < 3000 && got < n; ++i) {
        int64_t k = tp_verifier_poll(v, out + got, (size_t)(n - got));
        if (k < 0) return -1;
        got += (int)k;
        if (got < n) nap();
    }
    return got;
}

static tp_candidate between(int64_t query, int64_t match) {
    tp_candidate c;
    memset(&c, 0, sizeof c);
    c.has_keyframes = 1;
    c.query_keyframe = query;
    c.match_keyframe = match;
    c.query_keyframe_pose = (uint64_t)query;
    c.match_keyframe_pose = (uint64_t)match;
    c.scale = 1.0;
    c.rotation[0] = c.rotation[4] = c.rotation[8] = 1.0;
    c.score = 0.9;
    return c;
}

static unsigned char *read_all(const char *path, size_t size) {
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    unsigned char *buf = malloc(size);
    size_t got = buf ? fread(buf, 1, size, f) : 0;
    fclose(f);
    if (got != size) {
        free(buf);
        return NULL;
    }
    return buf;
}

int main(int argc, char **argv) {
    CHECK(tp_verifier_connect(NULL, 1.0) == NULL);
    CHECK(tp_verifier_poll(NULL, NULL, 0) == TP_ERROR);
    tp_verdict verdicts[4];

    if (argc == 3 && strcmp(argv[2], "absent") == 0) {
        tp_verifier *v = tp_verifier_connect(argv[1], 2.0);
        CHECK(v != NULL);
        CHECK(tp_verifier_wait(v, 0.2) == 0);
        tp_candidate c = between(13, 12);
        uint64_t id = tp_verifier_submit(v, &c);
        CHECK(id != 0);
        CHECK(collect(v, verdicts, 1) == 1);
        CHECK(verdicts[0].id == id && verdicts[0].outcome == TP_EXPIRED);
        printf("ok expired: %s\n", verdicts[0].reason);
        tp_verifier_free(v);
        return 0;
    }
    CHECK(argc == 6);
    uint32_t width = (uint32_t)atoi(argv[2]), height = (uint32_t)atoi(argv[3]);
    tp_verifier *v = tp_verifier_connect(argv[1], 20.0);
    CHECK(v != NULL);
    CHECK(tp_verifier_wait(v, 20.0) == 1);

    /* The KITTI odometry left grey camera of sequences 04-12. */
    tp_camera camera;
    memset(&camera, 0, sizeof camera);
    camera.kind = TP_CAMERA_PINHOLE;
    camera.width = width;
    camera.height = height;
    camera.params[0] = camera.params[1] = 707.0912;
    camera.params[2] = 601.8873;
    camera.params[3] = 183.1104;
    for (int k = 0; k < 2; ++k) {
        unsigned char *pixels = read_all(argv[4 + k], (size_t)width * height);
        CHECK(pixels != NULL);
        CHECK(tp_verifier_publish_keyframe(v, 12 + k, 0.1 * (12 + k), &camera, pixels, width) ==
              TP_ACCEPTED);
        CHECK(tp_verifier_publish_keyframe(v, 12 + k, 0.0, &camera, pixels, width - 1) ==
              TP_ERROR);
        free(pixels);
    }

    tp_candidate same_place = between(13, 12), unknown = between(13, 999999),
                 no_keyframes = between(13, 12);
    no_keyframes.has_keyframes = 0;
    CHECK(tp_verifier_submit(v, &no_keyframes) == 0);
    CHECK(strstr(tp_last_error(), "keyframes") != NULL);
    uint64_t confirmed_id = tp_verifier_submit(v, &same_place);
    uint64_t rejected_id = tp_verifier_submit(v, &unknown);
    CHECK(confirmed_id != 0 && rejected_id != 0 && confirmed_id != rejected_id);
    CHECK(collect(v, verdicts, 2) == 2);
    uint32_t inliers = 0;
    for (int i = 0; i < 2; ++i) {
        const tp_verdict *d = &verdicts[i];
        if (d->id == confirmed_id) {
            CHECK(d->outcome == TP_CONFIRMED);
            CHECK(d->query_keyframe == 13 && d->match_keyframe == 12);
            CHECK(d->inliers >= 30);
            double t = sqrt(d->match_t_query[0] * d->match_t_query[0] +
                            d->match_t_query[1] * d->match_t_query[1] +
                            d->match_t_query[2] * d->match_t_query[2]);
            CHECK(fabs(t - 1.0) < 1e-6);
            /* One frame apart: almost no rotation, motion along the axis. */
            CHECK(d->match_R_query[0] + d->match_R_query[4] + d->match_R_query[8] > 2.99);
            CHECK(fabs(d->match_t_query[2]) > 0.9);
            inliers = d->inliers;
        } else {
            CHECK(d->id == rejected_id);
            CHECK(d->outcome == TP_REJECTED);
            CHECK(strlen(d->reason) > 0);
        }
    }

    /* The verifier dies: the candidate sent next still gets its verdict. */
    printf("kill\n");
    fflush(stdout);
    char line[16];
    CHECK(fgets(line, sizeof line, stdin) != NULL);
    uint64_t orphan = tp_verifier_submit(v, &same_place);
    CHECK(orphan != 0);
    CHECK(collect(v, verdicts, 1) == 1);
    CHECK(verdicts[0].id == orphan && verdicts[0].outcome == TP_EXPIRED);
    printf("ok confirmed with %u inliers; after the kill: expired (%s)\n", inliers,
           verdicts[0].reason);
    tp_verifier_free(v);
    return 0;
}
