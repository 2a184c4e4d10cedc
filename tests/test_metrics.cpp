// The Prometheus exporter: what a scrape of /metrics reads after the seed devices'
// frames, its listen addresses, its series limit, a real HTTP scrape, and a real
// Prometheus server scraping it.
#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "input/sources.hpp"
#include "profiles/bus.hpp"
#include "support.hpp"
#include "telemetry/metrics.hpp"
#include "telemetry/telemetry.hpp"

namespace rtuscope {
namespace {

std::string read_file(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

std::string seed(const std::string& name) {
    return read_file(std::string(RTUSCOPE_SOURCE_DIR) + "/captures/seeds/" + name);
}

// An exporter on a free port of 127.0.0.1, fed by a TelemetrySink as `sniff` feeds it.
class Fed {
  public:
    explicit Fed(std::size_t max_series = 10000) {
        MetricsOptions options;
        options.listen = "127.0.0.1:0";
        options.bus = "seed";
        options.max_series = max_series;
        auto started = start_metrics(options, shared_);
        if (!started) {
            ADD_FAILURE() << started.error().to_string();
            return;
        }
        metrics_ = started->get();
        std::vector<std::unique_ptr<Exporter>> exporters;
        exporters.push_back(std::move(*started));
        sink_ = std::make_unique<TelemetrySink>(shared_, std::move(exporters));
    }

    void run(std::string content, InputFormat format, const Bus* bus) {
        ASSERT_NE(metrics_, nullptr);
        auto source = source_from_memory(std::move(content), "seed", format);
        ASSERT_TRUE(source) << source.error().to_string();
        PipelineOptions options;
        options.bus = bus;
        ASSERT_TRUE(run_pipeline(**source, options, *sink_));
    }

    [[nodiscard]] const Exporter& metrics() const { return *metrics_; }
    [[nodiscard]] std::string text() const { return metrics_text(*metrics_); }

  private:
    std::shared_ptr<SharedState> shared_ = std::make_shared<SharedState>();
    std::unique_ptr<TelemetrySink> sink_;
    const Exporter* metrics_ = nullptr;
};

// The lines of `text` that start with `prefix`.
std::vector<std::string> lines_starting(const std::string& text, const std::string& prefix) {
    std::vector<std::string> out;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) {
        if (line.rfind(prefix, 0) == 0) out.push_back(line);
    }
    return out;
}

bool has_line(const std::string& text, const std::string& line) {
    return ("\n" + text).find("\n" + line + "\n") != std::string::npos;
}

// The ZB-UVI485 manual's frames, its slaves 1 to 3 named.
std::string zb_uvi485_text() {
    Bus bus;
    for (std::uint8_t a = 1; a <= 3; ++a) EXPECT_TRUE(bus.assign(a, "zb-uvi485"));
    Fed fed;
    fed.run(seed("zb-uvi485.hex"), InputFormat::hex, &bus);
    return fed.text();
}

TEST(Metrics, ARegisterIsAGaugeWithItsSlaveTableAddressNameAndUnit) {
    const std::string text = zb_uvi485_text();
    // Slaves 1 and 3 answer 0x1818 = 616.8 µW/cm²; slave 2's answer has a bad CRC.
    EXPECT_TRUE(has_line(text,
                         "rtuscope_register{bus=\"seed\",slave=\"1\",table=\"holding\","
                         "address=\"0x0000\",name=\"uv_intensity\",unit=\"µW/cm²\"} 616.8"))
        << text;
    EXPECT_TRUE(has_line(text,
                         "rtuscope_register{bus=\"seed\",slave=\"3\",table=\"holding\","
                         "address=\"0x0000\",name=\"uv_intensity\",unit=\"µW/cm²\"} 616.8"))
        << text;
    EXPECT_TRUE(lines_starting(text, "rtuscope_register{bus=\"seed\",slave=\"2\"").empty()) << text;
    EXPECT_TRUE(has_line(text, "# TYPE rtuscope_register gauge")) << text;

    Bus pdu;
    ASSERT_TRUE(pdu.assign(1, "pdu485"));
    Fed fed;
    fed.run(seed("pdu485.hex"), InputFormat::hex, &pdu);
    EXPECT_TRUE(has_line(fed.text(),
                         "rtuscope_register{bus=\"seed\",slave=\"1\",table=\"holding\","
                         "address=\"0x0000\",name=\"voltage\",unit=\"V\"} 220.5"))
        << fed.text();
}

// The figures of `rtuscope stats --device 1=zb-uvi485 --device 2=zb-uvi485 --device
// 3=zb-uvi485 captures/seeds/zb-uvi485.hex`: slave 1 reads, sets its coefficient and its
// address, each answered; slave 2's answer has a bad CRC (broken).
TEST(Metrics, CountersAreThoseOfStats) {
    const std::string text = zb_uvi485_text();
    for (const char* line : {
             "rtuscope_requests_total{bus=\"seed\",slave=\"1\"} 3",
             "rtuscope_answers_total{bus=\"seed\",slave=\"1\"} 3",
             "rtuscope_requests_total{bus=\"seed\",slave=\"2\"} 1",
             "rtuscope_answers_total{bus=\"seed\",slave=\"2\"} 0",
             "rtuscope_crc_errors_total{bus=\"seed\",slave=\"2\"} 1",
             "rtuscope_crc_errors_total{bus=\"seed\",slave=\"1\"} 0",
             "rtuscope_no_answers_total{bus=\"seed\",slave=\"1\"} 0",
             "rtuscope_frames_total{bus=\"seed\",slave=\"2\",function=\"3\",kind=\"broken\"} 1",
             "rtuscope_frames_total{bus=\"seed\",slave=\"1\",function=\"4\",kind=\"answer\"} 1",
             "# TYPE rtuscope_frames_total counter",
             "rtuscope_noise_bytes_total{bus=\"seed\"} 0",
             "rtuscope_requests_total{bus=\"seed\",slave=\"3\"} 1",
             "rtuscope_answers_total{bus=\"seed\",slave=\"3\"} 1",
             "rtuscope_bytes_total{bus=\"seed\"} 77",
         }) {
        EXPECT_TRUE(has_line(text, line)) << line << "\n" << text;
    }
    // A hex log has no timing: no turnarounds, no utilisation.
    EXPECT_TRUE(lines_starting(text, "rtuscope_turnaround_seconds_count").empty()) << text;
    EXPECT_TRUE(lines_starting(text, "rtuscope_bus_utilisation_ratio{").empty()) << text;
}

// The figures of `rtuscope stats --bus captures/devices/zb-uvi485.bus.toml
// captures/devices/zb-uvi485.hex`: requests the device refuses by silence, a broadcast
// on its own broadcast address 255.
TEST(Metrics, NoAnswersAndBroadcastsAreThoseOfStats) {
    const std::string dir = std::string(RTUSCOPE_SOURCE_DIR) + "/captures/devices/";
    Bus bus;
    ASSERT_TRUE(load_bus_file(bus, dir + "zb-uvi485.bus.toml").empty());
    Fed fed;
    fed.run(read_file(dir + "zb-uvi485.hex"), InputFormat::hex, &bus);
    const std::string text = fed.text();
    for (const char* line : {
             "rtuscope_requests_total{bus=\"seed\",slave=\"1\"} 5",
             "rtuscope_answers_total{bus=\"seed\",slave=\"1\"} 3",
             "rtuscope_no_answers_total{bus=\"seed\",slave=\"1\"} 2",
             "rtuscope_no_answers_total{bus=\"seed\",slave=\"4\"} 1",
             "rtuscope_frames_total{bus=\"seed\",slave=\"1\",function=\"4\",kind=\"request\"} 2",
             "rtuscope_frames_total{bus=\"seed\",slave=\"255\",function=\"5\",kind=\"broadcast\"} 1",
             "rtuscope_bytes_total{bus=\"seed\"} 154",
         }) {
        EXPECT_TRUE(has_line(text, line)) << line << "\n" << text;
    }
}

TEST(Metrics, AnExceptionIsCountedByItsCode) {
    Bus pdu;
    ASSERT_TRUE(pdu.assign(1, "pdu485"));
    Fed fed;
    fed.run(seed("pdu485.hex"), InputFormat::hex, &pdu);
    EXPECT_TRUE(has_line(fed.text(), "rtuscope_exceptions_total{bus=\"seed\",slave=\"1\",code=\"2\"} 1"))
        << fed.text();
}

std::string capture(const std::vector<std::string>& lines) {
    std::string out = "# rtuscope capture v1\n# serial 9600 8N1\n";
    for (const auto& l : lines) out += l + "\n";
    return out;
}

TEST(Metrics, TurnaroundsFillCumulativeBucketsPerSlave) {
    // A capture's time is its chunk's end: slave 1's answers (7 characters at 9600 8N1,
    // 7.29 ms) start 1.5 ms and 30 ms after its requests end; slave 2 never answers.
    const std::string request1 = "01 03 00 00 00 01 84 0A";
    const std::string answer1 = "01 03 02 08 FD 7E 05";
    Fed fed;
    fed.run(capture({"0.000 " + request1, "0.0087917 " + answer1, "1.000 " + request1,
                     "1.0372917 " + answer1, "2.000 02 03 00 00 00 01 84 39"}),
            InputFormat::capture, nullptr);
    const std::string text = fed.text();
    for (const char* line : {
             "# TYPE rtuscope_turnaround_seconds histogram",
             "rtuscope_turnaround_seconds_count{bus=\"seed\",slave=\"1\"} 2",
             "rtuscope_turnaround_seconds_bucket{bus=\"seed\",slave=\"1\",le=\"0.001\"} 0",
             "rtuscope_turnaround_seconds_bucket{bus=\"seed\",slave=\"1\",le=\"0.005\"} 1",
             "rtuscope_turnaround_seconds_bucket{bus=\"seed\",slave=\"1\",le=\"0.002\"} 1",
             "rtuscope_turnaround_seconds_bucket{bus=\"seed\",slave=\"1\",le=\"0.02\"} 1",
             "rtuscope_turnaround_seconds_bucket{bus=\"seed\",slave=\"1\",le=\"0.05\"} 2",
             "rtuscope_turnaround_seconds_bucket{bus=\"seed\",slave=\"1\",le=\"1\"} 2",
             "rtuscope_turnaround_seconds_bucket{bus=\"seed\",slave=\"1\",le=\"+Inf\"} 2",
             "rtuscope_no_answers_total{bus=\"seed\",slave=\"2\"} 1",
         }) {
        EXPECT_TRUE(has_line(text, line)) << line << "\n" << text;
    }
    const auto sum = lines_starting(text, "rtuscope_turnaround_seconds_sum{bus=\"seed\",slave=\"1\"} ");
    ASSERT_EQ(sum.size(), 1U) << text;
    EXPECT_NEAR(std::stod(sum[0].substr(sum[0].rfind(' ') + 1)), 0.0315, 0.0001) << text;
    EXPECT_TRUE(lines_starting(text, "rtuscope_turnaround_seconds_count{bus=\"seed\",slave=\"2\"}")
                    .empty())
        << text;
    const auto busy = lines_starting(text, "rtuscope_bus_utilisation_ratio{bus=\"seed\"} ");
    ASSERT_EQ(busy.size(), 1U) << text;
    EXPECT_GT(std::stod(busy[0].substr(busy[0].rfind(' ') + 1)), 0.0);
    EXPECT_LT(std::stod(busy[0].substr(busy[0].rfind(' ') + 1)), 0.05);
}

TEST(Metrics, RegisterSeriesStopAtTheLimitLowestAddressesFirst) {
    Bus pdu;
    ASSERT_TRUE(pdu.assign(1, "pdu485"));
    Fed all;
    all.run(seed("pdu485.hex"), InputFormat::hex, &pdu);
    const std::size_t total = lines_starting(all.text(), "rtuscope_register{").size();
    ASSERT_GT(total, 3U) << all.text();
    EXPECT_TRUE(has_line(all.text(), "rtuscope_register_series_dropped{bus=\"seed\"} 0"));

    Fed capped(2);
    capped.run(seed("pdu485.hex"), InputFormat::hex, &pdu);
    const auto kept = lines_starting(capped.text(), "rtuscope_register{");
    ASSERT_EQ(kept.size(), 2U) << capped.text();
    EXPECT_NE(kept[0].find("address=\"0x0000\""), std::string::npos) << kept[0];
    EXPECT_NE(kept[1].find("address=\"0x0001\""), std::string::npos) << kept[1];
    EXPECT_TRUE(has_line(capped.text(), "rtuscope_register_series_dropped{bus=\"seed\"} " +
                                            std::to_string(total - 2)))
        << capped.text();
}

TEST(ParseListenAddress, APortAloneListensOnLoopback) {
    EXPECT_EQ(*parse_listen_address("9464"), "127.0.0.1:9464");
    EXPECT_EQ(*parse_listen_address(":9464"), "127.0.0.1:9464");
    EXPECT_EQ(*parse_listen_address("0"), "127.0.0.1:0");
}

TEST(ParseListenAddress, AnAddressIsKeptAsGiven) {
    EXPECT_EQ(*parse_listen_address("0.0.0.0:9464"), "0.0.0.0:9464");
    EXPECT_EQ(*parse_listen_address("[::1]:9464"), "[::1]:9464");
    EXPECT_EQ(*parse_listen_address("localhost:9464"), "localhost:9464");
}

TEST(ParseListenAddress, ABadPortOrAddressIsAnError) {
    for (const char* text : {"", ":", "abc", "9464x", "65536", "-1", "host:", "host:99999"}) {
        const auto r = parse_listen_address(text);
        ASSERT_FALSE(r) << text;
        EXPECT_NE(r.error().message.find("the port must be a number from 0 to 65535"),
                  std::string::npos)
            << r.error().message;
        EXPECT_NE(r.error().message.find(std::string("\"") + text + "\""), std::string::npos)
            << r.error().message;
    }
    const auto bare = parse_listen_address("::1:9464");
    ASSERT_FALSE(bare);
    EXPECT_NE(bare.error().message.find("[::1]:9464"), std::string::npos) << bare.error().message;
}

TEST(StartMetrics, AnAddressThatCannotBeBoundIsAnErrorNamingIt) {
    const auto shared = std::make_shared<SharedState>();
    MetricsOptions options;
    options.listen = "127.0.0.1:0";
    auto first = start_metrics(options, shared);
    ASSERT_TRUE(first) << first.error().to_string();
    const std::string taken = metrics_endpoint(**first);
    options.listen = taken;
    const auto second = start_metrics(options, shared);
    ASSERT_FALSE(second);
    EXPECT_EQ(second.error().message, "cannot listen on " + taken + ": Address already in use");
    // An address of no interface here (TEST-NET-1).
    options.listen = "192.0.2.1:9464";
    const auto foreign = start_metrics(options, shared);
    ASSERT_FALSE(foreign);
    EXPECT_EQ(foreign.error().message,
              "cannot listen on 192.0.2.1:9464: Cannot assign requested address");
    options.listen = "no-such-host.invalid:9464";
    const auto unknown = start_metrics(options, shared);
    ASSERT_FALSE(unknown);
    EXPECT_EQ(unknown.error().message, "cannot listen on no-such-host.invalid:9464: not an IPv4 "
                                       "address or a host name known here");
    options.listen = "bad";
    const auto bad = start_metrics(options, shared);
    ASSERT_FALSE(bad);
    EXPECT_NE(bad.error().message.find("the port must be a number"), std::string::npos);
}

TEST(StartMetrics, StopsAtOnce) {
    // civetweb's listening thread looks for the stop every 2 s: a run that ends must not
    // wait for it.
    MetricsOptions options;
    options.listen = "127.0.0.1:0";
    auto started = start_metrics(options, std::make_shared<SharedState>());
    ASSERT_TRUE(started) << started.error().to_string();
    const auto before = std::chrono::steady_clock::now();
    started->reset();
    EXPECT_LT(std::chrono::steady_clock::now() - before, std::chrono::milliseconds(1000));
}

// The port of "ADDR:PORT".
int port_of(const std::string& endpoint) {
    return std::stoi(endpoint.substr(endpoint.rfind(':') + 1));
}

// The whole answer (status line, headers, body) to GET `target` from 127.0.0.1:`port`;
// empty if the connection fails.
std::string http_get(int port, const std::string& target) {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    if (fd < 0) return {};
    timeval timeout{5, 0};
    ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(static_cast<std::uint16_t>(port));
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    std::string answer;
    // NOLINTNEXTLINE(cppcoreguidelines-pro-type-reinterpret-cast): the sockets API
    if (::connect(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) == 0) {
        const std::string request =
            "GET " + target + " HTTP/1.0\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n";
        if (::send(fd, request.data(), request.size(), 0) ==
            static_cast<ssize_t>(request.size())) {
            char buffer[4096];
            for (ssize_t n; (n = ::recv(fd, buffer, sizeof buffer, 0)) > 0;) {
                answer.append(buffer, static_cast<std::size_t>(n));
            }
        }
    }
    ::close(fd);
    return answer;
}

TEST(StartMetrics, ServesMetricsOverHttpOnTheBoundPort) {
    Bus bus;
    for (std::uint8_t a = 1; a <= 3; ++a) ASSERT_TRUE(bus.assign(a, "zb-uvi485"));
    Fed fed;
    fed.run(seed("zb-uvi485.hex"), InputFormat::hex, &bus);
    const std::string endpoint = metrics_endpoint(fed.metrics());
    ASSERT_EQ(endpoint.rfind("127.0.0.1:", 0), 0U) << endpoint;
    ASSERT_GT(port_of(endpoint), 0) << endpoint;

    const std::string answer = http_get(port_of(endpoint), "/metrics");
    EXPECT_EQ(answer.rfind("HTTP/1.1 200", 0), 0U) << answer;
    EXPECT_NE(answer.find("\r\n\r\n"), std::string::npos) << answer;
    EXPECT_NE(answer.find("\nrtuscope_register{bus=\"seed\",slave=\"1\",table=\"holding\","
                          "address=\"0x0000\",name=\"uv_intensity\",unit=\"µW/cm²\"} 616.8\n"),
              std::string::npos)
        << answer;
    EXPECT_EQ(fed.metrics().summary(), "metrics: 1 scrape of http://" + endpoint + "/metrics");
}

// A free TCP port of 127.0.0.1 (free when asked: another program may take it after).
int free_port() {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t size = sizeof address;
    int port = 0;
    // NOLINTBEGIN(cppcoreguidelines-pro-type-reinterpret-cast): the sockets API
    if (fd >= 0 && ::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0 &&
        ::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &size) == 0) {
        port = ntohs(address.sin_port);
    }
    // NOLINTEND(cppcoreguidelines-pro-type-reinterpret-cast)
    if (fd >= 0) ::close(fd);
    return port;
}

// A Prometheus server of its own (temporary storage, a free port), stopped at the end.
class PrometheusServer {
  public:
    PrometheusServer(const std::string& binary, const test::TempDir& dir, const std::string& target)
        : port_(free_port()) {
        const std::string config = dir.write("prometheus.yml",
                                             "global:\n"
                                             "  scrape_interval: 1s\n"
                                             "  evaluation_interval: 1s\n"
                                             "scrape_configs:\n"
                                             "  - job_name: rtuscope\n"
                                             "    static_configs:\n"
                                             "      - targets: ['" + target + "']\n");
        std::vector<std::string> args = {binary,
                                         "--config.file=" + config,
                                         "--storage.tsdb.path=" + dir.file("data"),
                                         "--web.listen-address=127.0.0.1:" + std::to_string(port_)};
        const std::string log = dir.file("prometheus.log");
        pid_ = ::fork();
        if (pid_ == 0) {
            const int out = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
            if (out >= 0) {
                ::dup2(out, 1);
                ::dup2(out, 2);
            }
            std::vector<char*> argv;
            for (auto& a : args) argv.push_back(a.data());
            argv.push_back(nullptr);
            ::execv(binary.c_str(), argv.data());
            ::_exit(127);
        }
    }
    ~PrometheusServer() {
        if (pid_ <= 0) return;
        ::kill(pid_, SIGTERM);
        int status = 0;
        for (int i = 0; i < 100; ++i) {
            if (::waitpid(pid_, &status, WNOHANG) == pid_) return;
            std::this_thread::sleep_for(std::chrono::milliseconds(50));
        }
        ::kill(pid_, SIGKILL);
        ::waitpid(pid_, &status, 0);
    }
    PrometheusServer(const PrometheusServer&) = delete;
    PrometheusServer& operator=(const PrometheusServer&) = delete;

    [[nodiscard]] bool started() const { return pid_ > 0 && port_ > 0; }
    [[nodiscard]] int port() const { return port_; }

  private:
    int port_;
    pid_t pid_ = -1;
};

TEST(StartMetrics, APrometheusServerScrapesTheRegisters) {
    const std::string binary = "/usr/bin/prometheus";
    if (::access(binary.c_str(), X_OK) != 0) {
        GTEST_SKIP() << binary << " is missing: install Debian's prometheus package to run this test";
    }
    Bus bus;
    for (std::uint8_t a = 1; a <= 3; ++a) ASSERT_TRUE(bus.assign(a, "zb-uvi485"));
    Fed fed;
    fed.run(seed("zb-uvi485.hex"), InputFormat::hex, &bus);
    const test::TempDir dir;
    const PrometheusServer server(binary, dir, metrics_endpoint(fed.metrics()));
    ASSERT_TRUE(server.started());

    // The query's answer once a scrape has been stored: Prometheus starts in about a
    // second and scrapes every second.
    std::string answer;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(12);
    while (std::chrono::steady_clock::now() < deadline) {
        answer = http_get(server.port(), "/api/v1/query?query=rtuscope_register");
        if (answer.find("616.8") != std::string::npos) break;
        std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
    EXPECT_NE(answer.find("\"status\":\"success\""), std::string::npos)
        << answer << "\n" << read_file(dir.file("prometheus.log"));
    EXPECT_NE(answer.find("\"__name__\":\"rtuscope_register\""), std::string::npos) << answer;
    EXPECT_NE(answer.find("\"name\":\"uv_intensity\""), std::string::npos) << answer;
    EXPECT_NE(answer.find("\"616.8\""), std::string::npos)
        << answer << "\n" << read_file(dir.file("prometheus.log"));
}

}  // namespace
}  // namespace rtuscope
