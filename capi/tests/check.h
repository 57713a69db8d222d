/* CHECK(cond) for the C test programs: on failure, prints the condition,
 * its line and the library's last error, and makes main return 1. */
#ifndef TURNPRINT_TEST_CHECK_H
#define TURNPRINT_TEST_CHECK_H

#include <stdio.h>

#include <turnprint.h>

#define CHECK(cond)                                                    \
    do {                                                               \
        if (!(cond)) {                                                 \
            printf("failed: %s (line %d; last error: %s)\n", #cond,    \
                   __LINE__, tp_last_error());                         \
            return 1;                                                  \
        }                                                              \
    } while (0)

#endif
