// Allocations on the decoding path: once its buffers have grown to fit the traffic, a
// decode allocates nothing per frame or per register value (issue #6), whichever output
// it writes. This binary replaces the global operator new to count calls; it is kept
// apart from rtuscope_tests, whose sanitizer build keeps the sanitizers' own operator new.
#include <gtest/gtest.h>

#include <atomic>
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
std::atomic<std::uint64_t> g_allocations{0};
}  // namespace

void* operator new(std::size_t size) {
    ++g_allocations;
    if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
    throw std::bad_alloc();
}
void* operator new[](std::size_t size) {
    return operator new(size);
}
// The nothrow forms too (std::stable_sort's buffer): each form must meet its own delete.
void* operator new(std::size_t size, const std::nothrow_t& /*tag*/) noexcept {
    ++g_allocations;
    return std::malloc(size == 0 ? 1 : size);
}
void* operator new[](std::size_t size, const std::nothrow_t& tag) noexcept {
    return operator new(size, tag);
}
// Not inlined: GCC would then see free() meet a pointer from `new` and call it a mismatch.
[[gnu::noinline]] void operator delete(void* p) noexcept {
    std::free(p);
}
[[gnu::noinline]] void operator delete[](void* p) noexcept {
    std::free(p);
}
[[gnu::noinline]] void operator delete(void* p, std::size_t /*size*/) noexcept {
    std::free(p);
}
[[gnu::noinline]] void operator delete[](void* p, std::size_t /*size*/) noexcept {
    std::free(p);
}
[[gnu::noinline]] void operator delete(void* p, const std::nothrow_t& /*tag*/) noexcept {
    std::free(p);
}
[[gnu::noinline]] void operator delete[](void* p, const std::nothrow_t& /*tag*/) noexcept {
    std::free(p);
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

// Allocations made by decoding `cycles` polls into the output `make_sink` gives.
std::uint64_t allocations_decoding(
    int cycles, const std::function<std::unique_ptr<RecordSink>(FILE*)>& make_sink) {
    Bus bus;
    EXPECT_TRUE(test::assign_seed_devices(bus));
    PipelineOptions options;
    options.bus = &bus;
    auto source = source_from_memory(seed_device_polls(cycles), "polls", InputFormat::raw);
    EXPECT_TRUE(source);
    std::unique_ptr<FILE, int (*)(FILE*)> null(std::fopen("/dev/null", "w"), &std::fclose);
    EXPECT_NE(null, nullptr);
    std::unique_ptr<RecordSink> sink = make_sink(null.get());
    Totals totals;
    const std::uint64_t before = g_allocations;
    EXPECT_TRUE(run_pipeline(**source, options, *sink, &totals));
    const std::uint64_t made = g_allocations - before;
    EXPECT_EQ(totals.records, 10U * static_cast<std::uint64_t>(cycles));
    EXPECT_EQ(totals.responses, 5U * static_cast<std::uint64_t>(cycles));
    return made;
}

void expect_no_allocation_per_frame(
    const std::function<std::unique_ptr<RecordSink>(FILE*)>& make_sink) {
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

}  // namespace
}  // namespace rtuscope
