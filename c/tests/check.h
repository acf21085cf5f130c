/* A minimal test harness: CHECK counts, reports failures and never aborts. */
#ifndef CHECK_H
#define CHECK_H

#include <stdio.h>

static int check_total, check_failed;

#define CHECK(cond) CHECKF(cond, "%s", "")

#define CHECKF(cond, ...)                                                                            \
    do {                                                                                             \
        check_total++;                                                                               \
        if (!(cond)) {                                                                               \
            check_failed++;                                                                          \
            fprintf(stderr, "%s:%d: failed: %s: ", __FILE__, __LINE__, #cond);                       \
            fprintf(stderr, __VA_ARGS__);                                                            \
            fputc('\n', stderr);                                                                     \
        }                                                                                            \
    } while (0)

/* Print the closing line and return the exit status. */
static int check_report(const char *suite)
{
    printf("%s: %d passed, %d failed\n", suite, check_total - check_failed, check_failed);
    return check_failed == 0 && check_total > 0 ? 0 : 1;
}

#endif /* CHECK_H */
