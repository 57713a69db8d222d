/*
 * turnprint from C and C++ (Python has its own package, crates/turnprint-python):
 * - the online loop-closure detector: push one pose at a time from the
 *   odometry thread (under a microsecond; matching runs on the detector's
 *   own worker thread), poll the candidates whenever convenient;
 * - the link to the visual verifier sidecar, which confirms candidates on
 *   the keyframes' images;
 * - whole paths: where two maps overlap (merging) and where one revisits
 *   itself.
 *
 * Build the library with
 *
 *     cargo build --release -p turnprint-capi
 *
 * and link target/release/libturnprint_c.a (with -lpthread -ldl -lm) or
 * target/release/libturnprint_c.so (--profile dist instead of --release:
 * the same without debug info, in target/dist). From CMake:
 * capi/CMakeLists.txt (target turnprint::turnprint); or pkg-config
 * turnprint once installed.
 *
 * Every function is safe to call with NULL pointers (it returns an error
 * code) and never lets a Rust panic cross into the caller: a failure
 * returns TP_ERROR (or NULL, or 0 where a function returns an id) and
 * tp_last_error() says why. A detector or verifier link is used from one
 * thread at a time.
 */
#ifndef TURNPRINT_H
#define TURNPRINT_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The detector (opaque). */
typedef struct tp_detector tp_detector;

/* Settings; tp_options_default fills in the library's defaults. */
typedef struct tp_options {
    /* Candidates emitted per finalised segment (default 3). */
    uint32_t top_k;
    /* Lowest score emitted, in [0, 1] (default 0.3). */
    double min_score;
    /* 1: also look for revisits farther away the longer the path in
     * between, for odometry that drifts strongly (default 1). */
    int drift_probe;
    /* 0: push never waits; when matching falls behind, the newest segment
     * is matched and the skipped ones are counted (live use, default).
     * 1: push waits for the worker (replaying a file: deterministic). */
    int wait_for_matching;
    /* Lowest score emitted for a candidate of the drift probe, whose
     * scores are low by design: the verifier judges it (default 0.005). */
    double drift_min_score;
    /* 1: also search near the current position in the map's own frame
     * (default 1). */
    int proximity;
    /* The query's own neighbourhood, left out of the search: the turning
     * (radians of integrated |curvature|) between a match and the query,
     * above 0 (default pi/2). */
    double exclusion_turning;
    /* Shape candidates verified per finalised segment, strongest first
     * (default 8): the matcher's work per segment. */
    uint32_t max_verify;
    /* Segments the worker's queue holds before push starts merging (or,
     * with wait_for_matching, waiting) (default 4). */
    uint32_t queue_capacity;
    /* A step longer than this many typical steps is a jump (GPS glitch, VO
     * failure) and goes through the jump filter (default 25). */
    double jump_factor;
    /* Matching threads, 1 to 64 (default 1), over one history: the
     * matchings of the hand-overs queued at once are shared out; the
     * candidates and the memory are the same with any number. 2 keeps up
     * with a file replay on two cores; 1 leaves the other cores to the
     * odometry. */
    uint32_t workers;
} tp_options;

/* One pose as odometry delivers it. */
typedef struct tp_pose {
    /* Timestamp in seconds, used when has_time is nonzero: must increase. */
    double t;
    int has_time;
    /* Position, any unit and frame. */
    double position[3];
    /* Keyframe id of this pose, or a negative number when it is none. */
    int64_t keyframe;
} tp_pose;

/* What tp_detector_push did with a pose (negative: an error). */
enum {
    TP_ACCEPTED = 0,
    TP_REJECTED_NON_FINITE = 1,   /* NaN or infinite coordinate or time */
    TP_REJECTED_OUT_OF_ORDER = 2, /* timestamp earlier than the last one */
    TP_REJECTED_DUPLICATE = 3,    /* timestamp equal to the last one */
    TP_ERROR = -1
};

/* Where a candidate came from. */
enum {
    TP_SOURCE_SHAPE = 0,       /* the shape search */
    TP_SOURCE_PROXIMITY = 1,   /* near the current position in the map */
    TP_SOURCE_DRIFT_PROBE = 2, /* farther away, for a drifting map */
    TP_SOURCE_NETWORK = 3      /* placed on the whole road network, drifting map */
};

/* A loop-closure candidate: the newest part of the path (query, later)
 * revisits an earlier part (match). Ranges are inclusive pose indices in
 * push order, counting rejected poses too; both ends of the match come
 * before those of the query, and the two ranges overlap only when the
 * common road is longer than one lap of a circuit driven again. The
 * similarity maps match
 * points onto the query part:
 *     p_query = scale * rotation * p_match + translation
 * with rotation row-major. Shape proposes; check it against images before
 * treating it as a constraint. */
typedef struct tp_candidate {
    uint64_t id;
    /* Index of the pose whose arrival produced it. */
    uint64_t at_pose;
    uint64_t query_first, query_last;
    uint64_t match_first, match_last;
    /* Score in [0, 1] and the ZNCC of the two curvature signatures. */
    double score, zncc;
    /* 1 when the two parts are driven in opposite directions. */
    int reversed;
    int source;
    double scale;
    double rotation[9];
    double translation[3];
    /* 1 when keyframes were given: the pair a verifier should compare
     * (tp_verifier_submit), and their pose indices. */
    int has_keyframes;
    int64_t query_keyframe, match_keyframe;
    uint64_t query_keyframe_pose, match_keyframe_pose;
} tp_candidate;

/* Counts of a finished run. */
typedef struct tp_summary {
    uint64_t poses, accepted;
    uint64_t non_finite, out_of_order, duplicate, outliers, jumps;
    uint64_t segments, candidates, skipped;
    /* Memory held by the history at the end. */
    uint64_t history_bytes;
    /* 1 when the matching was lost to an internal error
     * (tp_detector_finish then returns TP_ERROR). */
    uint64_t workers_lost;
    /* Batches of matchings shared out over more than one thread (see
     * tp_options.workers). */
    uint64_t parallel_batches;
    /* Poses taken although stamped before the last one, whose stamp alone
     * was ahead (stamped after the one before it too); a stamp before
     * both is out_of_order. */
    uint64_t stamps_ahead;
} tp_summary;

/* The library's default settings. Returns TP_ERROR when out is NULL. */
int tp_options_default(tp_options *out);

/* A detector and its worker thread; options NULL for the defaults. NULL on
 * failure (invalid options: tp_last_error()). */
tp_detector *tp_detector_new(const tp_options *options);

/* Feeds one pose: TP_ACCEPTED, a TP_REJECTED_* code (the pose is dropped
 * and counted, the detector goes on), or TP_ERROR. */
int tp_detector_push(tp_detector *detector, const tp_pose *pose);

/* Copies up to capacity candidates that arrived since the last poll into
 * out and returns how many; the rest wait for the next call. Returns 0
 * when there are none, TP_ERROR on NULL detector (or NULL out with a
 * nonzero capacity). */
int64_t tp_detector_poll(tp_detector *detector, tp_candidate *out, size_t capacity);

/* Ends the stream: the last segments are matched, the worker stops, the
 * remaining candidates wait for tp_detector_poll, and the counts go to
 * summary (may be NULL). Later pushes return TP_ERROR. Returns TP_ERROR,
 * with the summary filled, when a matching thread was lost (a bug: the
 * candidates polled are right, but some matchings' are missing). */
int tp_detector_finish(tp_detector *detector, tp_summary *summary);

/* Frees the detector (NULL is ignored). */
void tp_detector_free(tp_detector *detector);

/* The last error of this thread, or "" (valid until the next call). */
const char *tp_last_error(void);

/* ---- Whole paths: map merging and loops --------------------------------
 * A path is poses * 3 doubles (x y z per pose, any unit and frame). */

/* A hypothesis: the range of A and the range of B that are one road, and
 * the similarity mapping B onto A:
 *     p_A = scale * rotation * p_B + translation   (rotation row-major) */
typedef struct tp_hypothesis {
    uint64_t a_first, a_last;
    uint64_t b_first, b_last;
    double score, zncc;
    int reversed; /* 1 when B runs the other way */
    double scale;
    double rotation[9];
    double translation[3];
    double rmse;        /* residual of the overlap, A's units */
    double turning_deg; /* turning inside the overlap */
    double length;      /* matched length, A's units */
} tp_hypothesis;

/* Where path B overlaps path A (unknown scale, frame and direction): up to
 * capacity hypotheses, best first; returns how many, or TP_ERROR (too few
 * poses, a NaN, a path that never moves: tp_last_error()). */
int64_t tp_match_paths(const double *a, size_t a_poses, const double *b, size_t b_poses,
                       tp_hypothesis *out, size_t capacity);

/* Places path A revisits: A's range is the later part (query), B's the
 * earlier (match), both pose ranges of A; the similarity maps the earlier
 * part onto the later. Returns how many, or TP_ERROR. */
int64_t tp_find_loops(const double *a, size_t poses, tp_hypothesis *out, size_t capacity);

/* ---- The visual verifier sidecar --------------------------------------
 * Shape proposes, images decide. Run `turnprint-verifier --prefix P` next
 * to the VO process (cargo build --release --features verifier); the VO
 * publishes its keyframes and submits candidates over iceoryx2 shared
 * memory, and every submitted candidate ends in exactly one verdict:
 * confirmed (with the relative camera pose), rejected, or expired (no
 * verdict in time, or the verifier absent, gone or restarted). A verifier
 * that dies never stops the VO. */

/* The link to the verifier (opaque). */
typedef struct tp_verifier tp_verifier;

/* Camera models. */
enum {
    TP_CAMERA_PINHOLE = 0, /* params: fx fy cx cy k1 k2 p1 p2 */
    TP_CAMERA_FISHEYE = 1, /* params: fx fy cx cy k1 k2 k3 k4 (Kannala-Brandt) */
    TP_CAMERA_OMNI = 2     /* params: xi fx fy cx cy k1 k2 p1 p2 (Mei) */
};

typedef struct tp_camera {
    uint32_t kind;
    uint32_t width, height;
    double params[12]; /* unused entries zero */
} tp_camera;

/* How a candidate ended. */
enum { TP_CONFIRMED = 0, TP_REJECTED = 1, TP_EXPIRED = 2 };

typedef struct tp_verdict {
    /* The id tp_verifier_submit returned. */
    uint64_t id;
    int outcome;
    /* Feature matches supporting the pose (found, when rejected). */
    uint32_t inliers;
    int64_t query_keyframe, match_keyframe;
    /* Confirmed: the rotation taking query-camera bearings into the match
     * camera (row-major), and the query camera's centre seen from the match
     * camera (unit length; zero for a pure rotation). */
    double match_R_query[9];
    double match_t_query[3];
    /* Rejected or expired: why, as text. */
    char reason[64];
} tp_verdict;

/* Connects to the verifier services under prefix (the verifier's
 * --prefix); works whether or not the verifier runs yet. A candidate
 * without a verdict after timeout_s seconds expires. NULL on failure.
 * iceoryx2 logs errors only, unless IOX2_LOG_LEVEL says otherwise. */
tp_verifier *tp_verifier_connect(const char *prefix, double timeout_s);

/* Waits up to seconds for the verifier's heartbeat: 1 when heard, else 0. */
int tp_verifier_wait(tp_verifier *verifier, double seconds);

/* Publishes a keyframe: height rows of stride bytes of 8-bit grey pixels
 * (stride >= camera->width), copied once into shared memory. */
int tp_verifier_publish_keyframe(tp_verifier *verifier, int64_t keyframe, double t,
                                 const tp_camera *camera, const uint8_t *gray,
                                 size_t stride);

/* Submits a candidate of tp_detector_poll (it must have keyframes): returns
 * its verdict id, or 0 on error (ids are never 0). */
uint64_t tp_verifier_submit(tp_verifier *verifier, const tp_candidate *candidate);

/* Copies up to capacity verdicts reached since the last poll into out and
 * returns how many (never waits); the rest wait for the next call. */
int64_t tp_verifier_poll(tp_verifier *verifier, tp_verdict *out, size_t capacity);

/* Frees the link (NULL is ignored); undecided candidates are dropped. */
void tp_verifier_free(tp_verifier *verifier);

#ifdef __cplusplus
}
#endif

#endif /* TURNPRINT_H */
