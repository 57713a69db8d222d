/* Whole paths from C, run by tests/c_abi.rs:
 *
 *   merge_paths A.kitti B.tum
 *
 * reads a KITTI pose file (12 numbers a line, position in columns 4, 8,
 * 12) and a TUM file (t x y z ...), prints the hypotheses of
 * tp_match_paths(A, B) and of tp_find_loops(B), one line each, after
 * checking the bad-input codes. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <turnprint.h>

#include "check.h"

/* Positions of a KITTI (12 columns) or TUM (8 columns) file. */
static double *read_path(const char *path, int kitti, size_t *poses) {
    FILE *f = fopen(path, "r");
    if (!f) return NULL;
    size_t cap = 1024, n = 0;
    double *xyz = malloc(cap * 3 * sizeof *xyz);
    double v[12];
    int columns = kitti ? 12 : 8;
    for (;;) {
        int got = 0;
        for (; got < columns; ++got) {
            if (fscanf(f, "%lf", &v[got]) != 1) break;
        }
        if (got < columns) break;
        if (n == cap) {
            cap *= 2;
            xyz = realloc(xyz, cap * 3 * sizeof *xyz);
        }
        for (int k = 0; k < 3; ++k) {
            xyz[3 * n + k] = kitti ? v[3 + 4 * k] : v[1 + k];
        }
        ++n;
    }
    fclose(f);
    *poses = n;
    return xyz;
}

static void print(const char *what, const tp_hypothesis *h) {
    printf("%s a=%llu-%llu b=%llu-%llu score=%.4f scale=%.4f reversed=%d\n", what,
           (unsigned long long)h->a_first, (unsigned long long)h->a_last,
           (unsigned long long)h->b_first, (unsigned long long)h->b_last, h->score, h->scale,
           h->reversed);
}

int main(int argc, char **argv) {
    CHECK(argc == 3);
    size_t na = 0, nb = 0;
    double *a = read_path(argv[1], 1, &na), *b = read_path(argv[2], 0, &nb);
    CHECK(a != NULL && b != NULL && na > 1000 && nb > 1000);
    tp_hypothesis found[5];

    /* Bad input: codes and messages. */
    CHECK(tp_match_paths(NULL, na, b, nb, found, 5) == TP_ERROR);
    CHECK(tp_match_paths(a, na, b, nb, NULL, 5) == TP_ERROR);
    CHECK(tp_match_paths(a, 3, b, nb, found, 5) == TP_ERROR);
    CHECK(strstr(tp_last_error(), "poses") != NULL);
    double saved = b[3 * 10 + 1];
    b[3 * 10 + 1] = NAN;
    CHECK(tp_match_paths(a, na, b, nb, found, 5) == TP_ERROR);
    CHECK(strstr(tp_last_error(), "non-finite") != NULL);
    b[3 * 10 + 1] = saved;
    double still[3 * 200];
    for (int i = 0; i < 3 * 200; ++i) still[i] = 1.0;
    CHECK(tp_find_loops(still, 200, found, 5) == TP_ERROR);
    CHECK(strstr(tp_last_error(), "does not move") != NULL);

    int64_t n = tp_match_paths(a, na, b, nb, found, 5);
    CHECK(n >= 1 && n <= 5);
    for (int64_t i = 0; i < n; ++i) print("match", &found[i]);
    n = tp_find_loops(b, nb, found, 5);
    CHECK(n >= 1 && n <= 5);
    for (int64_t i = 0; i < n; ++i) print("loop", &found[i]);
    free(a);
    free(b);
    return 0;
}
