/* process_memory.h: the daemon's own memory, for /v1/stats and /metrics: resident (now and at
 * its peak, from /proc/self/status) and the C heap (glibc's mallinfo2: bytes in use, bytes free
 * but kept, bytes in mmap'd blocks), so that growth can be told apart: a leak grows in_use;
 * fragmentation grows free; memory outside the heap (the Vulkan driver's, thread stacks) grows
 * resident alone. */
#ifndef SRV_PROCESS_MEMORY_H
#define SRV_PROCESS_MEMORY_H

#include <stdint.h>

typedef struct srv_process_memory {
    uint64_t rss_bytes, peak_rss_bytes; /* 0 when /proc cannot be read */
    /* the C heap; all 0 where the allocator does not tell (e.g. under AddressSanitizer) */
    uint64_t heap_in_use_bytes; /* allocated and not freed (arenas and mmap'd blocks) */
    uint64_t heap_free_bytes;   /* free chunks the arenas keep */
    uint64_t heap_mmap_bytes;   /* blocks served by mmap (large allocations), part of in_use */
} srv_process_memory;

void srv_process_memory_read(srv_process_memory *m);

#endif
