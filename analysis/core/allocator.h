// RetainFreedMemory: keeps memory the process frees for its next use instead of handing the top
// of the heap back to the system after every call. An analysis allocates and frees vectors of
// tens to hundreds of KiB (a DBB pair: 3 600-sample signature columns, stacked traces); with
// glibc's default trim threshold (128 KiB) the heap shrinks after each analysis and the next one
// page-faults it back in, about a tenth of a DBB pair's analysis time. Called once at the start
// of the executables (server, command line, benchmarks); what is retained is bounded by the
// process's own peak use. A no-op on other C libraries.
#pragma once

namespace km {

void RetainFreedMemory();

}  // namespace km
