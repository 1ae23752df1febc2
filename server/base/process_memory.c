/* process_memory.c: resident memory from /proc/self/status, the heap from mallinfo2. */
#include "server/base/process_memory.h"

#include <malloc.h>
#include <stdio.h>
#include <string.h>

void srv_process_memory_read(srv_process_memory *m)
{
    memset(m, 0, sizeof *m);
    FILE *f = fopen("/proc/self/status", "r");
    if (f) {
        char line[256];
        unsigned long long kib;
        while (fgets(line, sizeof line, f)) {
            if (sscanf(line, "VmRSS: %llu kB", &kib) == 1) m->rss_bytes = kib * 1024;
            if (sscanf(line, "VmHWM: %llu kB", &kib) == 1) m->peak_rss_bytes = kib * 1024;
        }
        fclose(f);
    }
#if defined(__GLIBC__) && (__GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 33))
    struct mallinfo2 mi = mallinfo2();
    m->heap_in_use_bytes = mi.uordblks + mi.hblkhd;
    m->heap_free_bytes = mi.fordblks;
    m->heap_mmap_bytes = mi.hblkhd;
#endif
}
