#pragma once
// Large arrays on transparent huge pages (docs/performance.md, "Huge pages").

namespace qbond::cli {

/// Starts this program again with glibc's malloc asking for transparent huge pages
/// (GLIBC_TUNABLES=glibc.malloc.hugetlb=1) where the kernel gives them only when asked (its
/// `madvise` mode, Debian's default): a world of 10⁶ quanta then builds and takes its first step
/// in half the time, its first touch of each 4 KiB page being a page fault. Returns, changing
/// nothing for the commands that build no world (all but run, bench, view, experiment and
/// statics), when GLIBC_TUNABLES or QBOND_NO_HUGE_PAGES is set, under Valgrind (an exec would
/// leave it), when the kernel gives huge pages always or never, or when the exec fails. Call it
/// first in main: the exec starts the program from its beginning, with the same arguments.
void use_huge_pages(int argc, char** argv);

/// Whether this process's malloc asks for transparent huge pages (GLIBC_TUNABLES holds
/// glibc.malloc.hugetlb=1 or 2): what a benchmark's provenance records.
bool huge_pages_asked();

}  // namespace qbond::cli
