/*
 * fail_message.h — private: the library's one error-message writer, shared by the parameter and
 * state checks of every layer. Not installed.
 */
#ifndef AHC_FAIL_MESSAGE_H
#define AHC_FAIL_MESSAGE_H

#include <stddef.h>

/* Writes the printf-style message into msg (if msg and n > 0, truncated to n) and returns code. */
int ahc_fail_message(char *msg, size_t n, int code, const char *fmt, ...);

#endif
