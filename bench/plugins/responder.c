/* The trivial exec-protocol responder: answers every case "miss" with its id, flushing per
   line as the protocol asks, so a benchmark measures the protocol and not an intersector. */
#include <stdio.h>
#include <string.h>

int main(void) {
  static char line[1 << 16];
  setvbuf(stdout, NULL, _IOLBF, 1 << 16);
  while (fgets(line, sizeof line, stdin)) {
    const char* id = strstr(line, "\"id\":\"");
    if (!id) return 1;
    id += 6;
    const char* end = strchr(id, '"');
    if (!end) return 1;
    printf("{\"id\":\"%.*s\",\"class\":\"miss\"}\n", (int)(end - id), id);
  }
  return 0;
}
