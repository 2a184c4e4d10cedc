// Allocations on the decoding path: once its buffers have grown to fit the traffic, a
// decode allocates nothing per frame or per register value (issue #6), whichever output
// it writes; and the heap it keeps stays bounded on traffic crafted to grow it. This
// binary replaces the global operator new to count calls and the bytes in use; it is kept
// apart from rtuscope_tests, whose sanitizer build keeps the sanitizers' own operator new.
#include <gtest/gtest.h>
#include <malloc.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <memory>
#include <new>
#include <string>
#include <vector>

#include "rtuscope/pipeline.hpp"
#include "rtuscope/sinks.hpp"
#include "rtuscope/sources.hpp"
#include "support.hpp"

namespace {
// The tests run on one thread.
std::uint64_t g_allocations = 0;
std::size_t g_heap_bytes = 0;  // in use now (as malloc counts them)
std::size_t g_heap_peak = 0;   // the most in use since it was last set

void* counted(void* p) {
    if (p != nullptr) {
        ++g_allocations;
        g_heap_bytes += malloc_usable_size(p);
        g_heap_peak = std::max(g_heap_peak, g_heap_bytes);
    }
    return p;
}

void release(void* p) {
    if (p != nullptr) g_heap_bytes -= malloc_usable_size(p);
    std::free(p);
}
}  // namespace

// None inlined: GCC would then see free() meet a pointer from `new`, or a `delete` one from
// malloc(), and call it a mismatch.
[[gnu::noinline]] void* operator new(std::size_t size) {
    if (void* p = counted(std::malloc(size == 0 ? 1 : size))) return p;
    throw std::bad_alloc();
}
void* operator new[](std::size_t size) {
    return operator new(size);
}
// The nothrow forms too (std::stable_sort's buffer): each form must meet its own delete.
[[gnu::noinline]] void* operator new(std::size_t size, const std::nothrow_t& /*tag*/) noexcept {
    return counted(std::malloc(size == 0 ? 1 : size));
}
void* operator new[](std::size_t size, const std::nothrow_t& tag) noexcept {
    return operator new(size, tag);
}
[[gnu::noinline]] void operator delete(void* p) noexcept {
    release(p);
}
[[gnu::noinline]] void operator delete[](void* p) noexcept {
    release(p);
}
[[gnu::noinline]] void operator delete(void* p, std::size_t /*size*/) noexcept {
    release(p);
}
[[gnu::noinline]] void operator delete[](void* p, std::size_t /*size*/) noexcept {
    release(p);
}
[[gnu::noinline]] void operator delete(void* p, const std::nothrow_t& /*tag*/) noexcept {
    release(p);
}
[[gnu::noinline]] void operator delete[](void* p, const std::nothrow_t& /*tag*/) noexcept {
    release(p);
}

namespace rtuscope {
namespace {

using test::Bytes;

void append_frame(std::string& out, const Bytes& frame) {
    const Bytes sent = test::with_crc(frame);
    out.append(sent.begin(), sent.end());
}

// A read of `count` registers from 0x0000 and its answer, with words that differ from
// register to register (out of range, unlabelled: every kind of value note).
void append_read(std::string& out, std::uint8_t slave, std::uint8_t count) {
    append_frame(out, {slave, 0x03, 0x00, 0x00, 0x00, count});
    Bytes answer = {slave, 0x03, static_cast<std::uint8_t>(2 * count)};
    for (unsigned i = 0; i < count; ++i) {
        answer.push_back(static_cast<std::uint8_t>(0x40 + 7 * i));
        answer.push_back(static_cast<std::uint8_t>(0x13 * i));
    }
    append_frame(out, answer);
}

// `cycles` polls of the four seed devices as a raw dump: whole tables with named,
// scaled, enumerated, 32-bit and unlisted registers, and a write to a read-only one.
std::string seed_device_polls(int cycles) {
    std::string dump;
    for (int c = 0; c < cycles; ++c) {
        append_read(dump, 1, 1);   // zb-uvi485
        append_read(dump, 2, 20);  // sensor-analyser: named and unlisted registers
        append_read(dump, 3, 29);  // pdu485: the whole table
        const Bytes write = {3, 0x06, 0x00, 0x00, 0x12, 0x34};  // voltage is read-only
        append_frame(dump, write);
        append_frame(dump, write);
        append_read(dump, 4, 16);  // zyi-relay: labelled channels
    }
    return dump;
}

using MakeSink = std::function<std::unique_ptr<RecordSink>(FILE*)>;

// What decoding a raw dump of the seed devices' bus (1-4) into `make_sink`'s output counts.
struct Decoded {
    Totals totals;
    std::uint64_t allocations = 0;
    std::size_t heap_peak = 0;  // above the heap in use before
};

Decoded decode_seed_bus(std::string dump, const MakeSink& make_sink) {
    Bus bus;
    EXPECT_TRUE(test::assign_seed_devices(bus));
    PipelineOptions options;
    options.bus = &bus;
    auto source = source_from_memory(std::move(dump), "dump", InputFormat::raw);
    EXPECT_TRUE(source);
    std::unique_ptr<FILE, int (*)(FILE*)> null(std::fopen("/dev/null", "w"), &std::fclose);
    EXPECT_NE(null, nullptr);
    std::unique_ptr<RecordSink> sink = make_sink(null.get());
    Decoded decoded;
    const std::uint64_t allocations_before = g_allocations;
    const std::size_t heap_before = g_heap_bytes;
    g_heap_peak = g_heap_bytes;
    EXPECT_TRUE(run_pipeline(**source, options, *sink, &decoded.totals));
    decoded.allocations = g_allocations - allocations_before;
    decoded.heap_peak = g_heap_peak - heap_before;
    return decoded;
}

// Allocations made by decoding `cycles` polls into the output `make_sink` gives.
std::uint64_t allocations_decoding(int cycles, const MakeSink& make_sink) {
    const Decoded decoded = decode_seed_bus(seed_device_polls(cycles), make_sink);
    EXPECT_EQ(decoded.totals.records, 10U * static_cast<std::uint64_t>(cycles));
    EXPECT_EQ(decoded.totals.responses, 5U * static_cast<std::uint64_t>(cycles));
    return decoded.allocations;
}

void expect_no_allocation_per_frame(const MakeSink& make_sink) {
    // Twice the polls, the same allocations: none per frame or per value. (Each run is
    // over 64 KiB, the framer's window, so that its buffers reach their working size in
    // both: 400 polls are 80 KB.)
    const std::uint64_t for_400 = allocations_decoding(400, make_sink);
    const std::uint64_t for_800 = allocations_decoding(800, make_sink);
    EXPECT_EQ(for_800, for_400) << "400 cycles: " << for_400 << ", 800 cycles: " << for_800;
}

TEST(Allocations, NonePerFrameDecodingToText) {
    expect_no_allocation_per_frame([](FILE* f) { return make_text_sink(f, TextOptions{}); });
}

TEST(Allocations, NonePerFrameDecodingToCsv) {
    expect_no_allocation_per_frame([](FILE* f) { return make_csv_sink(f); });
}

TEST(Allocations, NonePerFrameDecodingToJsonLines) {
    expect_no_allocation_per_frame([](FILE* f) { return make_jsonl_sink(f); });
}

TEST(Allocations, NonePerFrameDecodingToTheValuesCsv) {
    expect_no_allocation_per_frame([](FILE* f) { return make_values_csv_sink(f); });
}

// Peak RSS below 32 MiB whatever the capture (issue #6): the pairing stage keeps a few
// records' buffers, not one per slot a wait once grew. A read nobody answers, 200 frames
// held behind it, then 400 writes of 1,968 coils to the relay controller that go
// unanswered too (a master retrying a dead slave): each write's values are ~500 KB.
// Their records went round all 256 slots the wait had grown, each keeping its values:
// 130 MB. A few records' worth now.
TEST(Memory, UnansweredLargeWritesAfterAWaitKeepAFewRecords) {
    std::string dump;
    append_frame(dump, {9, 0x03, 0x00, 0x00, 0x00, 0x01});
    for (int i = 0; i < 200; ++i) append_frame(dump, {2, 0x83, 0x02});
    const Bytes header = {4, 0x0F, 0x00, 0x00, 0x07, 0xB0, 246};  // 1,968 coils from 0
    Bytes write(header.size() + 246, 0x55);
    std::copy(header.begin(), header.end(), write.begin());
    for (int i = 0; i < 400; ++i) append_frame(dump, write);
    const Decoded decoded = decode_seed_bus(dump, [](FILE* f) { return make_csv_sink(f); });
    EXPECT_EQ(decoded.totals.records, 601U);
    EXPECT_LT(decoded.heap_peak, std::size_t{8} << 20U) << decoded.heap_peak << " bytes";
}

}  // namespace
}  // namespace rtuscope
