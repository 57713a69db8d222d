// A visual-odometry loop in C++ with turnprint's online detector: one push
// per pose, candidates polled as they come. Here the "odometry" is a TUM
// file (t x y z qx qy qz qw) read line by line.
//
//   cargo build --release -p turnprint-capi
//   c++ -O2 -Icapi/include capi/examples/vo_loop.cpp target/release/libturnprint_c.a -lpthread -ldl -lm -o vo_loop
//   ./vo_loop ../shared/data/kitti_orbslam2_vio/00_orbslam2_tum.txt [--wait]
//
// --wait makes push wait for the matcher, so the candidates are the same
// on every run (a replay); without it push never waits, as a live VO needs.
#include <turnprint.h>

#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>

static void print(const tp_candidate &c) {
    std::printf("candidate id=%llu at_pose=%llu query=%llu-%llu match=%llu-%llu "
                "score=%.4f source=%d reversed=%d keyframes=%lld-%lld\n",
                (unsigned long long)c.id, (unsigned long long)c.at_pose,
                (unsigned long long)c.query_first, (unsigned long long)c.query_last,
                (unsigned long long)c.match_first, (unsigned long long)c.match_last,
                c.score, c.source, c.reversed, (long long)c.query_keyframe,
                (long long)c.match_keyframe);
}

// Polls until nothing is waiting.
static void drain(tp_detector *detector) {
    tp_candidate batch[8];
    int64_t n;
    while ((n = tp_detector_poll(detector, batch, 8)) > 0) {
        for (int64_t i = 0; i < n; ++i) print(batch[i]);
    }
}

int main(int argc, char **argv) {
    if (argc < 2) {
        std::fprintf(stderr, "usage: vo_loop POSES.tum [--wait]\n");
        return 2;
    }
    tp_options options;
    tp_options_default(&options);
    options.wait_for_matching = argc > 2 && std::strcmp(argv[2], "--wait") == 0;
    tp_detector *detector = tp_detector_new(&options);
    if (!detector) {
        std::fprintf(stderr, "vo_loop: %s\n", tp_last_error());
        return 1;
    }
    std::ifstream file(argv[1]);
    if (!file) {
        std::fprintf(stderr, "vo_loop: cannot read %s\n", argv[1]);
        tp_detector_free(detector);
        return 1;
    }
    std::string line;
    int64_t index = 0;
    while (std::getline(file, line)) {
        if (line.empty() || line[0] == '#') continue;
        std::istringstream fields(line);
        tp_pose pose{};
        if (!(fields >> pose.t >> pose.position[0] >> pose.position[1] >> pose.position[2])) {
            std::fprintf(stderr, "vo_loop: bad line: %s\n", line.c_str());
            continue;
        }
        pose.has_time = 1;
        pose.keyframe = index % 5 == 0 ? index : -1;  // every fifth pose a keyframe
        ++index;
        if (tp_detector_push(detector, &pose) < 0) {
            std::fprintf(stderr, "vo_loop: %s\n", tp_last_error());
            break;
        }
        drain(detector);  // in a real VO: whenever the loop has a moment
    }
    tp_summary summary;
    if (tp_detector_finish(detector, &summary) < 0) {
        std::fprintf(stderr, "vo_loop: %s\n", tp_last_error());
    }
    drain(detector);
    // Replayed faster than any VO runs, the live policy skips the segments
    // that arrive while the matcher is busy: `skipped` counts them.
    std::printf("summary poses=%llu accepted=%llu segments=%llu candidates=%llu "
                "skipped=%llu history_bytes=%llu\n",
                (unsigned long long)summary.poses, (unsigned long long)summary.accepted,
                (unsigned long long)summary.segments, (unsigned long long)summary.candidates,
                (unsigned long long)summary.skipped, (unsigned long long)summary.history_bytes);
    tp_detector_free(detector);
    return 0;
}
