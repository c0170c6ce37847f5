/* The `leap` command line. Exit codes: 0 success, 1 runtime failure (message names the
 * file and the problem), 2 usage error (one-line reason). */
#ifndef LEAP_CLI_H
#define LEAP_CLI_H

#ifdef __cplusplus
extern "C" {
#endif

int leap_cli_main(int argc, char **argv);

#ifdef __cplusplus
}
#endif
#endif
