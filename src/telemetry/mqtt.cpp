#include "telemetry/mqtt.hpp"

#include <fmt/format.h>
#include <mosquitto.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <deque>
#include <fstream>
#include <mutex>
#include <optional>
#include <thread>
#include <utility>
#include <vector>

#include "output/fields.hpp"
#include "profiles/profile.hpp"

namespace rtuscope {

namespace {

constexpr std::uint16_t kMqttPort = 1883;
constexpr std::uint16_t kMqttsPort = 8883;
constexpr std::string_view kDefaultPrefix = "rtuscope";

}  // namespace

Result<MqttUrl> parse_mqtt_url(std::string_view text) {
    const auto fail = [&](std::string_view why) {
        return Error(fmt::format("MQTT URL '{}': {}", text, why));
    };
    MqttUrl url;
    std::string_view rest;
    if (text.starts_with("mqtt://")) {
        rest = text.substr(7);
    } else if (text.starts_with("mqtts://")) {
        url.tls = true;
        rest = text.substr(8);
    } else {
        return fail("it must start with mqtt:// or mqtts://");
    }
    url.port = url.tls ? kMqttsPort : kMqttPort;
    const std::size_t slash = rest.find('/');
    const std::string_view authority = rest.substr(0, slash);
    std::string_view path = slash == std::string_view::npos ? "" : rest.substr(slash + 1);
    if (authority.find('@') != std::string_view::npos) {
        return fail(
            "credentials do not go in the URL: set RTUSCOPE_MQTT_USERNAME and "
            "RTUSCOPE_MQTT_PASSWORD or --mqtt-password-file");
    }
    std::string_view host = authority;
    std::string_view port_text;
    bool has_port = false;
    if (authority.starts_with('[')) {
        const std::size_t close = authority.find(']');
        if (close == std::string_view::npos) return fail("the IPv6 address has no closing ']'");
        host = authority.substr(1, close - 1);
        const std::string_view after = authority.substr(close + 1);
        if (!after.empty()) {
            if (after[0] != ':') return fail("a ':' and the port must follow the IPv6 address");
            port_text = after.substr(1);
            has_port = true;
        }
    } else if (const std::size_t colon = authority.find(':'); colon != std::string_view::npos) {
        if (authority.find(':', colon + 1) != std::string_view::npos) {
            return fail("an IPv6 address goes in brackets: mqtt://[::1]:1883");
        }
        host = authority.substr(0, colon);
        port_text = authority.substr(colon + 1);
        has_port = true;
    }
    if (host.empty()) return fail("it has no host");
    for (const char c : host) {
        if (static_cast<unsigned char>(c) <= ' ' || c == '?' || c == '#') {
            return fail(fmt::format("the host '{}' is not a host name or address", host));
        }
    }
    url.host = host;
    if (has_port) {
        unsigned port = 0;
        const auto [end, ec] = std::from_chars(port_text.data(), port_text.data() + port_text.size(), port);
        if (port_text.empty() || ec != std::errc{} || end != port_text.data() + port_text.size() ||
            port == 0 || port > 65535) {
            return fail(fmt::format("the port '{}' is not a number from 1 to 65535", port_text));
        }
        url.port = static_cast<std::uint16_t>(port);
    }
    while (path.ends_with('/')) path.remove_suffix(1);
    if (path.empty()) {
        url.prefix = kDefaultPrefix;
        return url;
    }
    if (const std::size_t bad = path.find_first_of("+#?"); bad != std::string_view::npos) {
        return fail(fmt::format("the topic prefix '{}' holds '{}', which a topic cannot", path,
                                path[bad]));
    }
    if (path.starts_with('/') || path.find("//") != std::string_view::npos) {
        return fail(fmt::format("the topic prefix '{}' has an empty level", path));
    }
    if (path.starts_with('$')) {
        return fail(fmt::format("the topic prefix '{}' starts with '$', which the broker keeps "
                                "for itself", path));
    }
    if (mosquitto_validate_utf8(path.data(), static_cast<int>(path.size())) != MOSQ_ERR_SUCCESS) {
        return fail("the topic prefix is not valid UTF-8");
    }
    url.prefix = path;
    return url;
}

namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;
using std::chrono::seconds;

constexpr int kKeepaliveSeconds = 30;
constexpr int kLoopMilliseconds = 50;  // the longest a new message waits to go out
constexpr auto kFirstRetry = milliseconds(250);
constexpr auto kLastRetry = seconds(10);
constexpr auto kConnectTimeout = seconds(10);
constexpr auto kFlushBound = seconds(2);
constexpr auto kDisconnectBound = milliseconds(500);
constexpr std::size_t kMaxInflight = 1000;  // published, awaiting the broker's PUBACK
constexpr Nanos kDefaultOffline = 30 * kNanosPerSecond;
constexpr std::uint64_t kOfflineCycles = 3;
constexpr Nanos kCheckEvery = 100'000'000;  // slaves' availability, on the records' clock
constexpr Nanos kShortestInterval = kNanosPerSecond;

struct Message {
    std::string topic;
    std::string payload;
    bool retain = true;
};

void init_library() {
    static std::once_flag once;
    std::call_once(once, [] { mosquitto_lib_init(); });
}

// "Connection Refused: not authorised." gives "not authorised".
std::string refusal_reason(int connack) {
    std::string_view text = mosquitto_connack_string(connack);
    if (const std::size_t colon = text.find(": "); colon != std::string_view::npos) {
        text.remove_prefix(colon + 2);
    }
    while (text.ends_with('.')) text.remove_suffix(1);
    return std::string(text);
}

// The connection to the broker, on a thread of its own that alone touches the mosquitto
// client: connects (and reconnects, with a growing delay), publishes what the pipeline's
// thread queued, counts acknowledgements. The queue is bounded: the oldest message goes
// when it is full, and is counted as dropped.
class Connection {
  public:
    Connection(const MqttOptions& options, std::string status_topic)
        : options_(options), status_topic_(std::move(status_topic)) {}
    ~Connection() { stop(); }
    Connection(const Connection&) = delete;
    Connection& operator=(const Connection&) = delete;

    // Sets the client up; an Error for settings that can never work.
    Status open();

    void push(Message&& message) {
        const std::lock_guard lock(mutex_);
        if (stopped_) {
            ++dropped_;
            return;
        }
        if (outbox_.size() >= std::max<std::size_t>(options_.queue_limit, 1)) {
            outbox_.pop_front();
            ++dropped_;
        }
        outbox_.push_back(std::move(message));
    }

    // Waits, at most until `deadline`, for a connection (or a refusal).
    void wait_connected(Clock::time_point deadline) {
        std::unique_lock lock(mutex_);
        settled_.wait_until(lock, deadline, [&] { return connected_ || refused_ || stopped_; });
    }

    // Sends what is queued (waiting at most until `deadline` for the broker), then
    // disconnects cleanly, so that the last will is not published, and ends the thread.
    void finish(Clock::time_point deadline) {
        {
            std::unique_lock lock(mutex_);
            if (!refused_) {
                settled_.wait_until(lock, deadline, [&] {
                    return stopped_ || (outbox_.empty() && inflight_ == 0 && connected_);
                });
            }
        }
        stop();
    }

    void stop() {
        {
            const std::lock_guard lock(mutex_);
            quit_ = true;
        }
        wake_.notify_all();
        if (thread_.joinable()) thread_.join();
    }

    // True once after each (re)connection: the retained state is to be published again.
    bool take_republish() { return republish_.exchange(false); }

    [[nodiscard]] std::uint64_t published() const { return published_.load(); }
    [[nodiscard]] std::uint64_t dropped() const {
        const std::lock_guard lock(mutex_);
        return dropped_;
    }
    [[nodiscard]] bool ever_connected() const { return ever_connected_.load(); }
    [[nodiscard]] bool refused() const {
        const std::lock_guard lock(mutex_);
        return refused_;
    }
    [[nodiscard]] std::string last_failure() const {
        const std::lock_guard lock(mutex_);
        return last_failure_;
    }

  private:
    void run();
    void publish_queued();
    void connection_failed(int rc);
    void refuse(const std::string& why);

    static void on_connect(mosquitto* /*client*/, void* self, int rc) {
        static_cast<Connection*>(self)->connected(rc);
    }
    static void on_disconnect(mosquitto* /*client*/, void* self, int /*rc*/) {
        auto* c = static_cast<Connection*>(self);
        const std::lock_guard lock(c->mutex_);
        c->connected_ = false;
    }
    static void on_publish(mosquitto* /*client*/, void* self, int /*mid*/) {
        auto* c = static_cast<Connection*>(self);
        ++c->published_;
        {
            const std::lock_guard lock(c->mutex_);
            if (c->inflight_ > 0) --c->inflight_;
        }
        c->settled_.notify_all();
    }
    static void on_log(mosquitto* /*client*/, void* self, int level, const char* text) {
        if (level != MOSQ_LOG_ERR || text == nullptr) return;
        auto* c = static_cast<Connection*>(self);
        const std::lock_guard lock(c->mutex_);
        c->last_log_error_ = text;
    }
    void connected(int rc);

    MqttOptions options_;
    std::string status_topic_;
    std::unique_ptr<mosquitto, decltype(&mosquitto_destroy)> client_{nullptr, &mosquitto_destroy};
    std::thread thread_;

    mutable std::mutex mutex_;
    std::condition_variable wake_;     // quit_
    std::condition_variable settled_;  // the queue emptied and acknowledged, or quit_
    std::deque<Message> outbox_;
    std::uint64_t dropped_ = 0;
    std::size_t inflight_ = 0;
    bool quit_ = false;
    bool stopped_ = false;
    bool connected_ = false;
    bool refused_ = false;
    bool reported_ = false;
    std::string last_failure_;
    std::string last_log_error_;

    std::atomic<bool> republish_{false};
    std::atomic<bool> ever_connected_{false};
    std::atomic<std::uint64_t> published_{0};
    Clock::duration retry_ = kFirstRetry;  // the connection's thread's
};

Status readable(const std::string& path, std::string_view what) {
    std::ifstream in(path);
    if (!in) {
        return Error(fmt::format("cannot read the {} '{}': {}", what, path, std::strerror(errno)));
    }
    return ok_status();
}

Status Connection::open() {
    init_library();
    const MqttUrl& url = options_.url;
    const bool tls_files = !options_.ca_file.empty() || !options_.cert_file.empty() ||
                           !options_.key_file.empty();
    if (tls_files && !url.tls) {
        return Error(fmt::format("TLS files are given but the MQTT URL is mqtt://{}:{}: use mqtts://",
                                 url.host, url.port));
    }
    if (options_.cert_file.empty() != options_.key_file.empty()) {
        return Error("a client certificate needs its key, and a key its certificate (--mqtt-cert, --mqtt-key)");
    }
    if (!options_.password.empty() && options_.username.empty()) {
        return Error("an MQTT password needs a user name (RTUSCOPE_MQTT_USERNAME)");
    }
    const std::string client_id =
        fmt::format("rtuscope-{}-{}", safe_name(options_.bus), static_cast<long>(::getpid()));
    client_.reset(mosquitto_new(client_id.c_str(), true, this));
    if (!client_) return Error(fmt::format("cannot create an MQTT client: {}", std::strerror(errno)));
    mosquitto* c = client_.get();
    mosquitto_connect_callback_set(c, &Connection::on_connect);
    mosquitto_disconnect_callback_set(c, &Connection::on_disconnect);
    mosquitto_publish_callback_set(c, &Connection::on_publish);
    mosquitto_log_callback_set(c, &Connection::on_log);
    if (!options_.username.empty() &&
        mosquitto_username_pw_set(c, options_.username.c_str(),
                                  options_.password.empty() ? nullptr : options_.password.c_str()) !=
            MOSQ_ERR_SUCCESS) {
        return Error("the MQTT user name or password is not valid UTF-8");
    }
    if (url.tls) {
        for (const auto& [path, what] : {std::pair{options_.ca_file, "CA file"},
                                         std::pair{options_.cert_file, "client certificate"},
                                         std::pair{options_.key_file, "client key"}}) {
            if (path.empty()) continue;
            if (Status s = readable(path, what); !s) return s;
        }
        const char* ca = options_.ca_file.empty() ? nullptr : options_.ca_file.c_str();
        const char* ca_dir = ca == nullptr ? "/etc/ssl/certs" : nullptr;
        if (ca == nullptr) mosquitto_int_option(c, MOSQ_OPT_TLS_USE_OS_CERTS, 1);
        const int rc = mosquitto_tls_set(
            c, ca, ca_dir, options_.cert_file.empty() ? nullptr : options_.cert_file.c_str(),
            options_.key_file.empty() ? nullptr : options_.key_file.c_str(), nullptr);
        if (rc != MOSQ_ERR_SUCCESS) {
            return Error(fmt::format("cannot set up TLS for MQTT: {}", mosquitto_strerror(rc)));
        }
    }
    // Set before connecting: the broker says "offline" for us if we vanish.
    if (mosquitto_will_set(c, status_topic_.c_str(), 7, "offline", 1, true) != MOSQ_ERR_SUCCESS) {
        return Error(fmt::format("the MQTT topic '{}' is not valid", status_topic_));
    }
    thread_ = std::thread([this] { run(); });
    return ok_status();
}

void Connection::connected(int rc) {
    if (rc != 0) {
        refuse(refusal_reason(rc));
        return;
    }
    {
        const std::lock_guard lock(mutex_);
        connected_ = true;
        inflight_ = 0;  // the client resends what was in flight itself
    }
    retry_ = kFirstRetry;
    ever_connected_ = true;
    int mid = 0;
    if (mosquitto_publish(client_.get(), &mid, status_topic_.c_str(), 6, "online", 1, true) ==
        MOSQ_ERR_SUCCESS) {
        const std::lock_guard lock(mutex_);
        ++inflight_;
    }
    republish_ = true;
    settled_.notify_all();
}

void Connection::refuse(const std::string& why) {
    bool report = false;
    {
        const std::lock_guard lock(mutex_);
        refused_ = true;
        report = !reported_;
        reported_ = true;
        last_failure_ = "refused: " + why;
    }
    if (report) {
        fmt::print(stderr, "rtuscope: mqtt: broker {}:{} refused the connection: {}\n",
                   options_.url.host, options_.url.port, why);
        std::fflush(stderr);
    }
    if (options_.required && options_.stop != nullptr) options_.stop->store(true);
    settled_.notify_all();
}

void Connection::connection_failed(int rc) {
    if (rc == MOSQ_ERR_TLS) {
        std::string detail;
        {
            const std::lock_guard lock(mutex_);
            detail = last_log_error_;
        }
        // "OpenSSL Error[0]: error:0A000086:SSL routines::certificate verify failed"
        if (const std::size_t colon = detail.rfind(':'); colon != std::string::npos) {
            detail.erase(0, colon + 1);
        }
        refuse(detail.empty() ? std::string("TLS handshake failed") : "TLS: " + detail);
        return;
    }
    const std::lock_guard lock(mutex_);
    if (refused_) return;  // the refusal says more than the closed socket after it
    last_failure_ = rc == MOSQ_ERR_ERRNO ? std::strerror(errno) : mosquitto_strerror(rc);
}

void Connection::publish_queued() {
    for (;;) {
        Message m;
        {
            const std::lock_guard lock(mutex_);
            if (!connected_ || outbox_.empty() || inflight_ >= kMaxInflight) return;
            m = std::move(outbox_.front());
            outbox_.pop_front();
        }
        int mid = 0;
        const int rc = mosquitto_publish(client_.get(), &mid, m.topic.c_str(),
                                         static_cast<int>(m.payload.size()), m.payload.data(), 1,
                                         m.retain);
        const std::lock_guard lock(mutex_);
        if (rc == MOSQ_ERR_SUCCESS) {
            ++inflight_;
        } else if (rc == MOSQ_ERR_NO_CONN || rc == MOSQ_ERR_CONN_LOST || rc == MOSQ_ERR_ERRNO) {
            outbox_.push_front(std::move(m));  // for the next connection
            return;
        } else {
            ++dropped_;  // one the broker can never take (too long, not UTF-8)
        }
    }
}

void Connection::run() {
    mosquitto* c = client_.get();
    const MqttUrl& url = options_.url;
    bool open = false;  // a socket: connecting or connected
    Clock::time_point next_attempt = Clock::now();
    Clock::time_point attempt_started;
    const auto retry_later = [&] {
        open = false;
        {
            const std::lock_guard lock(mutex_);
            connected_ = false;
        }
        next_attempt = Clock::now() + retry_;
        retry_ = std::min<Clock::duration>(retry_ * 2, kLastRetry);
    };
    for (;;) {
        {
            std::unique_lock lock(mutex_);
            if (!open) wake_.wait_until(lock, next_attempt, [&] { return quit_; });
            if (quit_) break;
        }
        if (!open) {
            attempt_started = Clock::now();
            const int rc = mosquitto_connect_async(c, url.host.c_str(), url.port, kKeepaliveSeconds);
            if (rc != MOSQ_ERR_SUCCESS) {
                connection_failed(rc);
                retry_later();
                continue;
            }
            open = true;
        }
        publish_queued();
        const int rc = mosquitto_loop(c, kLoopMilliseconds, 1);
        if (rc != MOSQ_ERR_SUCCESS) {
            connection_failed(rc);
            retry_later();
        } else if (Clock::now() - attempt_started > kConnectTimeout) {
            bool up = false;
            {
                const std::lock_guard lock(mutex_);
                up = connected_;
            }
            if (!up) retry_later();  // the next attempt closes this socket
        }
        settled_.notify_all();
    }
    bool up = false;
    {
        const std::lock_guard lock(mutex_);
        up = connected_;
    }
    if (up && mosquitto_disconnect(c) == MOSQ_ERR_SUCCESS) {
        const auto deadline = Clock::now() + kDisconnectBound;
        while (mosquitto_socket(c) != -1 && Clock::now() < deadline) {
            if (mosquitto_loop(c, 20, 1) != MOSQ_ERR_SUCCESS) break;
        }
    }
    const std::lock_guard lock(mutex_);
    dropped_ += outbox_.size();  // never sent
    outbox_.clear();
    stopped_ = true;
    connected_ = false;
}

// JSON objects written field by field.
class JsonObject {
  public:
    JsonObject& string(std::string_view key, std::string_view value) {
        name(key);
        append_json_string(text_, value);
        return *this;
    }
    // `json` is a JSON value already (a number, an object, null ...).
    JsonObject& raw(std::string_view key, std::string_view json) {
        name(key);
        text_ += json;
        return *this;
    }
    JsonObject& number(std::string_view key, std::uint64_t value) {
        name(key);
        fmt::format_to(std::back_inserter(text_), "{}", value);
        return *this;
    }
    std::string take() {
        text_ += '}';
        return std::move(text_);
    }

  private:
    void name(std::string_view key) {
        if (text_.size() > 1) text_ += ',';
        append_json_string(text_, key);
        text_ += ':';
    }
    std::string text_ = "{";
};

// -?(0|[1-9][0-9]*)(.[0-9]+)?([eE][+-]?[0-9]+)?: what JSON takes as a number (a profile's
// value "220.5" is one; "inf" or ".5", which from_chars reads, are not).
bool is_json_number(std::string_view s) {
    std::size_t i = 0;
    const auto digits = [&] {
        const std::size_t from = i;
        while (i < s.size() && s[i] >= '0' && s[i] <= '9') ++i;
        return i - from;
    };
    if (i < s.size() && s[i] == '-') ++i;
    const std::size_t first = i;
    const std::size_t n = digits();
    if (n == 0 || (n > 1 && s[first] == '0')) return false;
    if (i < s.size() && s[i] == '.') {
        ++i;
        if (digits() == 0) return false;
    }
    if (i < s.size() && (s[i] == 'e' || s[i] == 'E')) {
        ++i;
        if (i < s.size() && (s[i] == '+' || s[i] == '-')) ++i;
        if (digits() == 0) return false;
    }
    return i == s.size();
}

// Seconds on the records' clock with milliseconds (Unix time for live input, pcaps and
// captures with absolute times), or null for input without times.
std::string json_time(Nanos t) {
    if (!has_time(t)) return "null";
    const std::int64_t ms = floor_div(t, 1'000'000);
    const std::int64_t size = ms < 0 ? -ms : ms;
    return fmt::format("{}{}.{:03}", ms < 0 ? "-" : "", size / 1000, size % 1000);
}

std::string json_ms(std::optional<Nanos> d) {
    return d ? fmt::format("{:.3f}", static_cast<double>(*d) / 1e6) : std::string("null");
}

// Home Assistant's classes for a unit: what a sensor of it measures.
struct UnitClass {
    std::string_view unit;
    std::string_view device_class;
    std::string_view state_class;
};
constexpr std::array kUnitClasses = {
    UnitClass{"V", "voltage", "measurement"},    UnitClass{"mV", "voltage", "measurement"},
    UnitClass{"A", "current", "measurement"},    UnitClass{"mA", "current", "measurement"},
    UnitClass{"W", "power", "measurement"},      UnitClass{"kW", "power", "measurement"},
    UnitClass{"kWh", "energy", "total_increasing"}, UnitClass{"Wh", "energy", "total_increasing"},
    UnitClass{"°C", "temperature", "measurement"}, UnitClass{"°F", "temperature", "measurement"},
    UnitClass{"Hz", "frequency", "measurement"}, UnitClass{"Pa", "pressure", "measurement"},
    UnitClass{"hPa", "pressure", "measurement"}, UnitClass{"kPa", "pressure", "measurement"},
    UnitClass{"bar", "pressure", "measurement"}, UnitClass{"mbar", "pressure", "measurement"},
    // A per cent is a humidity only where the register's name says so (below).
    UnitClass{"%", "humidity", "measurement"},
};

bool contains_word(std::string_view name, std::string_view word) {
    std::string lower(name);
    std::transform(lower.begin(), lower.end(), lower.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return lower.find(word) != std::string::npos;
}

bool equals_lower(std::string_view a, std::string_view lower) {
    return a.size() == lower.size() &&
           std::equal(a.begin(), a.end(), lower.begin(),
                      [](char x, char y) { return std::tolower(static_cast<unsigned char>(x)) == y; });
}

// The profile's entry of a register, nullptr without one.
const Register* profile_register(const BusState& state, const RegisterState& r) {
    const SlaveState* slave = state.slave(r.key.slave);
    if (slave == nullptr || slave->profile == nullptr) return nullptr;
    return slave->profile->register_at(std::string(state.table_name(r.key.table)), r.key.address);
}

struct Binary {
    std::string on;
    std::string off;
};

// A value with two states, on and off: a coil or discrete input, or a register whose
// profile labels its values 0 and 1 "off" and "on" (a relay's state).
std::optional<Binary> binary_of(const RegisterState& r, const Register* reg) {
    const bool bit_table = r.key.table == static_cast<std::uint8_t>(DataTable::coils) ||
                           r.key.table == static_cast<std::uint8_t>(DataTable::discrete_inputs);
    const bool two_labels = reg != nullptr && reg->type == ValueType::enumeration &&
                            reg->labels.size() == 2 && reg->labels.contains(0) &&
                            reg->labels.contains(1);
    if (bit_table) {
        if (two_labels) return Binary{reg->labels.at(1), reg->labels.at(0)};
        if (reg == nullptr || reg->type != ValueType::string) return Binary{"1", "0"};
        return std::nullopt;
    }
    if (two_labels && equals_lower(reg->labels.at(1), "on") && equals_lower(reg->labels.at(0), "off")) {
        return Binary{reg->labels.at(1), reg->labels.at(0)};
    }
    return std::nullopt;
}

class MqttExporter final : public Exporter {
  public:
    MqttExporter(const MqttOptions& options, std::unique_ptr<Connection> connection)
        : options_(options),
          connection_(std::move(connection)),
          bus_(safe_name(options.bus.empty() ? std::string("bus") : options.bus)),
          base_(options.url.prefix + "/" + bus_),
          interval_(std::max(options.interval, kShortestInterval)) {}
    ~MqttExporter() override { connection_->stop(); }
    MqttExporter(const MqttExporter&) = delete;
    MqttExporter& operator=(const MqttExporter&) = delete;

    void begin(const BusState& /*state*/) override {
        if (options_.ha_discovery) publish_bridge_discovery();
    }
    void record(const BusState& state, const Record& record) override;
    void tick(const BusState& state, Nanos now) override;
    void end(const BusState& state) override;
    [[nodiscard]] std::string summary() const override;
    [[nodiscard]] std::optional<std::uint64_t> messages_dropped() const override {
        return connection_->dropped();
    }
    [[nodiscard]] bool failed() const override {
        return options_.required && connection_->refused();
    }

  private:
    enum class Availability : std::uint8_t { unknown, online, offline };
    struct Watched {  // a slave, for its availability
        bool seen = false;
        Availability status = Availability::unknown;
        Nanos first_request = kNoTime;
        Nanos last_answer = kNoTime;
        // Its main poll when last looked at, to time its cycle by.
        PollKey poll;
        std::uint64_t poll_requests = 0;
        Nanos poll_at = kNoTime;
        Nanos cycle = kNoTime;
    };
    struct Published {  // a slot's last published value
        bool seen = false;
        std::uint32_t key = 0;
        std::string value;
    };

    void push(std::string topic, std::string payload, bool retain = true) {
        connection_->push({std::move(topic), std::move(payload), retain});
    }
    [[nodiscard]] std::string register_topic(const BusState& state, const RegisterState& r) const;
    [[nodiscard]] std::string value_payload(const BusState& state, const RegisterState& r,
                                            std::uint64_t request = 0) const;
    void publish_value(const BusState& state, std::uint32_t slot, bool always);
    void publish_write(const BusState& state, const RegisterState& r, const Record& record);
    void publish_discovery(const BusState& state, const RegisterState& r);
    void add_discovery_common(JsonObject& json, const BusState& state,
                              const RegisterState& r) const;
    void publish_bridge_discovery();
    void publish_slave_health(const BusState& state, std::uint8_t address);
    void publish_bus_health(const BusState& state, Nanos now);
    void publish_status(std::uint8_t address, Availability status);
    void publish_everything(const BusState& state, Nanos now);
    void saw_slave(const Record& record);
    void check_slaves(const BusState& state, Nanos now);
    void time_driven(const BusState& state, Nanos now);
    void periodic(const BusState& state, Nanos now);

    MqttOptions options_;
    std::unique_ptr<Connection> connection_;
    std::string bus_;   // the topic level
    std::string base_;  // PREFIX/BUS
    Nanos interval_;
    std::array<Watched, 256> slaves_{};
    std::vector<std::uint8_t> seen_slaves_;
    std::vector<Published> published_;
    Nanos last_check_ = kNoTime;
    Nanos last_periodic_ = kNoTime;
    bool ended_ = false;
};

std::string MqttExporter::register_topic(const BusState& state, const RegisterState& r) const {
    const std::string_view name = state.text(r.name);
    if (!name.empty()) return safe_name(name);
    return fmt::format("{}_0x{:04x}", safe_name(state.table_name(r.key.table)), r.key.address);
}

std::string MqttExporter::value_payload(const BusState& state, const RegisterState& r,
                                        std::uint64_t request) const {
    JsonObject json;
    if (r.numeric && is_json_number(r.value)) {
        json.raw("value", r.value);
    } else {
        json.string("value", r.value);
    }
    json.string("unit", state.text(r.unit));
    std::string raw;
    const bool bit_table = r.key.table == static_cast<std::uint8_t>(DataTable::coils) ||
                           r.key.table == static_cast<std::uint8_t>(DataTable::discrete_inputs);
    if (bit_table) {
        raw = r.raw[0] != 0 ? "1" : "0";
    } else {
        for (std::size_t i = 0; i < std::min<std::size_t>(r.raw_words, r.raw.size()); ++i) {
            fmt::format_to(std::back_inserter(raw), "{}0x{:04X}", i == 0 ? "" : " ", r.raw[i]);
        }
        if (r.raw_words > r.raw.size()) raw += " ...";
    }
    json.string("raw", raw);
    // A bit field's named bits, each 0 or 1: what its binary sensors read.
    const Register* reg = profile_register(state, r);
    if (reg != nullptr && reg->type == ValueType::bits && !reg->labels.empty()) {
        JsonObject bits;
        for (const auto& [bit, label] : reg->labels) {
            bits.number(label, (r.raw[0] >> bit) & 1U);
        }
        json.raw("bits", bits.take());
    }
    json.raw("time", json_time(r.last_update));
    if (request != 0) json.number("request", request);
    return json.take();
}

void MqttExporter::publish_value(const BusState& state, std::uint32_t slot, bool always) {
    const RegisterState& r = state.at_slot(slot);
    if (r.raw_words == 0) return;  // a slot not set yet
    // A command word written into a number register ("clear the energy counter") is an
    // event ($write), not the register's value.
    if (r.written && !r.numeric) {
        const Register* reg = profile_register(state, r);
        if (reg != nullptr && is_numeric(reg->type)) return;
    }
    if (published_.size() < state.slot_count()) published_.resize(state.slot_count());
    Published& p = published_[slot];
    const bool fresh = !p.seen || p.key != r.key.packed();  // a slot reused for another
    if (!always && !fresh && p.value == r.value) return;
    if (fresh && options_.ha_discovery) publish_discovery(state, r);
    push(fmt::format("{}/{}/{}", base_, r.key.slave, register_topic(state, r)),
         value_payload(state, r));
    p.seen = true;
    p.key = r.key.packed();
    p.value = r.value;
}

void MqttExporter::publish_write(const BusState& state, const RegisterState& r,
                                 const Record& record) {
    push(fmt::format("{}/{}/{}/$write", base_, r.key.slave, register_topic(state, r)),
         value_payload(state, r, record.number), false);
}

// The parts of a register's discovery config that every entity of it shares: its state
// topic, availability and device.
void MqttExporter::add_discovery_common(JsonObject& json, const BusState& state,
                                        const RegisterState& r) const {
    const SlaveState* slave = state.slave(r.key.slave);
    const Profile* profile = slave != nullptr ? slave->profile : nullptr;
    json.string("state_topic",
                fmt::format("{}/{}/{}", base_, r.key.slave, register_topic(state, r)));
    JsonObject bus_status;
    bus_status.string("topic", base_ + "/$status");
    JsonObject slave_status;
    slave_status.string("topic", fmt::format("{}/{}/$status", base_, r.key.slave));
    json.raw("availability", "[" + bus_status.take() + "," + slave_status.take() + "]")
        .string("availability_mode", "all");
    JsonObject device;
    std::string ids = "[";
    append_json_string(ids, fmt::format("rtuscope_{}_{}", bus_, r.key.slave));
    ids += ']';
    device.raw("identifiers", ids)
        .string("name", profile != nullptr
                            ? fmt::format("slave {} ({})", r.key.slave, profile->name)
                            : fmt::format("slave {}", r.key.slave));
    if (profile != nullptr) device.string("model", profile->name);
    device.string("manufacturer", "rtuscope").string("via_device", "rtuscope_" + bus_);
    json.raw("device", device.take());
}

void MqttExporter::publish_discovery(const BusState& state, const RegisterState& r) {
    const Register* reg = profile_register(state, r);
    const std::string topic_level = register_topic(state, r);
    const std::string id = fmt::format("rtuscope_{}_{}_{}", bus_, r.key.slave, topic_level);
    const std::optional<Binary> binary = binary_of(r, reg);
    // A class the profile gives ("" for none) wins over the one the unit implies.
    const auto put_class = [&](JsonObject& json, std::string_view key,
                               const std::optional<std::string>& given, std::string_view derived) {
        const std::string_view value = given ? std::string_view(*given) : derived;
        if (!value.empty()) json.string(key, value);
    };

    JsonObject json;
    json.string("name", topic_level)
        .string("unique_id", id)
        .string("object_id", id)
        .string("value_template", "{{ value_json.value }}");
    // The profile's unit: a command written has none.
    const std::string_view unit = reg != nullptr ? std::string_view(reg->unit) : state.text(r.unit);
    if (binary) {
        json.string("payload_on", binary->on).string("payload_off", binary->off);
        if (reg != nullptr) put_class(json, "device_class", reg->ha_device_class, {});
    } else {
        if (!unit.empty()) json.string("unit_of_measurement", unit);
        const auto* cls = std::find_if(kUnitClasses.begin(), kUnitClasses.end(),
                                       [&](const UnitClass& u) { return u.unit == unit; });
        const bool humidity_unit = unit == "%";
        const bool applies = cls != kUnitClasses.end() &&
                             (!humidity_unit || contains_word(state.text(r.name), "humidity"));
        // By the profile's type where there is one: a write's command word ("clear the
        // energy counter") leaves a number register a number register.
        const bool numeric = reg != nullptr ? is_numeric(reg->type) : r.numeric;
        const std::optional<std::string> no_override;
        put_class(json, "device_class", reg != nullptr ? reg->ha_device_class : no_override,
                  numeric && applies ? cls->device_class : std::string_view());
        put_class(json, "state_class", reg != nullptr ? reg->ha_state_class : no_override,
                  !numeric ? std::string_view() : applies ? cls->state_class : "measurement");
    }
    add_discovery_common(json, state, r);
    push(fmt::format("{}/{}/{}/config", options_.ha_prefix, binary ? "binary_sensor" : "sensor", id),
         json.take());

    // A bit field: besides the text of its set bits, one binary sensor per named bit, read
    // from the payload's "bits".
    if (reg == nullptr || reg->type != ValueType::bits) return;
    for (const auto& [bit, label] : reg->labels) {
        const std::string bit_id = fmt::format("{}_{}", id, safe_name(label));
        std::string key;
        append_json_string(key, label);
        JsonObject bit_json;
        bit_json.string("name", fmt::format("{} {}", topic_level, label))
            .string("unique_id", bit_id)
            .string("object_id", bit_id)
            .string("value_template",
                    fmt::format("{{{{ 'ON' if value_json.bits[{}] else 'OFF' }}}}", key))
            .string("payload_on", "ON")
            .string("payload_off", "OFF");
        add_discovery_common(bit_json, state, r);
        push(fmt::format("{}/binary_sensor/{}/config", options_.ha_prefix, bit_id), bit_json.take());
    }
}

// The sniffer itself, which every slave's device is reached through: its bus's
// utilisation.
void MqttExporter::publish_bridge_discovery() {
    const std::string id = "rtuscope_" + bus_;
    JsonObject availability;
    availability.string("topic", base_ + "/$status");
    std::string ids = "[";
    append_json_string(ids, id);
    ids += ']';
    JsonObject device;
    device.raw("identifiers", ids)
        .string("name", "rtuscope " + bus_)
        .string("model", "rtuscope")
        .string("manufacturer", "rtuscope");
    JsonObject json;
    json.string("name", "bus utilisation")
        .string("unique_id", id + "_utilisation")
        .string("object_id", id + "_utilisation")
        .string("state_topic", base_ + "/$bus")
        .string("value_template", "{{ value_json.utilisation }}")
        .string("unit_of_measurement", "%")
        .string("state_class", "measurement")
        .raw("availability", "[" + availability.take() + "]")
        .raw("device", device.take());
    push(fmt::format("{}/sensor/{}_utilisation/config", options_.ha_prefix, id), json.take());
}

void MqttExporter::publish_slave_health(const BusState& state, std::uint8_t address) {
    const SlaveState* s = state.slave(address);
    if (s == nullptr) return;
    const FunctionStats f = state.figures(address);
    JsonObject json;
    json.number("requests", f.requests);
    json.raw("answered", f.requests == 0
                             ? std::string("null")
                             : fmt::format("{:.1f}", 100.0 * static_cast<double>(f.answers + f.exceptions) /
                                                         static_cast<double>(f.requests)));
    json.raw("turnaround_p50_ms", json_ms(s->turnarounds.percentile(50)))
        .raw("turnaround_p95_ms", json_ms(s->turnarounds.percentile(95)))
        .number("exceptions", f.exceptions)
        .number("no_answer", f.no_answer)
        .number("crc_errors", f.crc_errors)
        .raw("last_seen", json_time(s->last_seen))
        .raw("last_answer", json_time(slaves_[address].last_answer));
    push(fmt::format("{}/{}/$health", base_, address), json.take());
}

void MqttExporter::publish_bus_health(const BusState& state, Nanos now) {
    const BusStats& stats = state.stats();
    std::uint64_t answer_errors = 0;
    for (const auto& [key, row] : stats.functions()) answer_errors += row.exceptions + row.no_answer;
    const std::optional<double> utilisation = stats.utilisation();
    JsonObject json;
    json.number("frames", stats.bus().frames)
        .number("bytes", stats.bus().bytes)
        .raw("utilisation", utilisation ? fmt::format("{:.2f}", *utilisation) : std::string("null"))
        .number("errors", stats.bus().invalid + stats.bus().noise_runs + answer_errors)
        .number("errors_last_minute", state.errors().within(now, PerSecond::kSeconds))
        .number("slaves", state.slaves().size())
        .number("registers", state.register_count())
        .number("dropped", connection_->dropped());
    push(base_ + "/$bus", json.take());
}

void MqttExporter::publish_status(std::uint8_t address, Availability status) {
    slaves_[address].status = status;
    push(fmt::format("{}/{}/$status", base_, address),
         status == Availability::online ? "online" : "offline");
}

void MqttExporter::publish_everything(const BusState& state, Nanos now) {
    if (options_.ha_discovery) publish_bridge_discovery();
    // Discovery again for every register: the broker may have lost its retained messages.
    for (Published& p : published_) p.seen = false;
    for (std::uint32_t slot = 0; slot < state.slot_count(); ++slot) {
        publish_value(state, slot, true);
    }
    for (const std::uint8_t address : seen_slaves_) {
        if (slaves_[address].status != Availability::unknown) {
            publish_status(address, slaves_[address].status);
        }
        publish_slave_health(state, address);
    }
    publish_bus_health(state, now);
}

void MqttExporter::saw_slave(const Record& record) {
    const bool answer = record.kind == Kind::response || record.kind == Kind::exception;
    if (!answer && !(record.kind == Kind::request && record.awaits_answer)) return;
    const std::uint8_t address = record.frame.slave();
    Watched& w = slaves_[address];
    if (!w.seen) {
        w.seen = true;
        seen_slaves_.push_back(address);
    }
    const Nanos at = record.frame.start;
    if (!answer) {
        if (!has_time(w.first_request)) w.first_request = at;
        return;
    }
    if (has_time(at)) w.last_answer = at;
    if (w.status != Availability::online) publish_status(address, Availability::online);
}

// A slave is offline once it has not answered for 3 of its poll cycles (its most frequent
// poll's, timed between two looks at it), or for 30 s while no cycle is known.
void MqttExporter::check_slaves(const BusState& state, Nanos now) {
    const auto& polls = state.stats().polls();
    for (const std::uint8_t address : seen_slaves_) {
        Watched& w = slaves_[address];
        const std::pair<const PollKey, PollStats>* main = nullptr;
        for (auto it = polls.lower_bound(PollKey{address, 0, {}, 0});
             it != polls.end() && it->first.slave == address; ++it) {
            if (main == nullptr || it->second.requests > main->second.requests) main = &*it;
        }
        if (main != nullptr && has_time(main->second.last_start)) {
            const PollStats& p = main->second;
            if (!has_time(w.poll_at) || !(main->first == w.poll) || p.requests < w.poll_requests) {
                w.poll = main->first;
                w.poll_requests = p.requests;
                w.poll_at = p.last_start;
            } else if (p.requests > w.poll_requests && p.last_start > w.poll_at) {
                w.cycle = (p.last_start - w.poll_at) / static_cast<Nanos>(p.requests - w.poll_requests);
                w.poll_requests = p.requests;
                w.poll_at = p.last_start;
            }
        }
        const Nanos since = has_time(w.last_answer) ? w.last_answer : w.first_request;
        if (!has_time(since) || w.status == Availability::offline) continue;
        const Nanos limit = has_time(w.cycle) ? static_cast<Nanos>(kOfflineCycles) * w.cycle
                                              : kDefaultOffline;
        if (now - since > limit) publish_status(address, Availability::offline);
    }
}

// Every value, each slave's health and the bus's, once an interval: a value is on the
// broker at most one interval old however seldom it changes.
void MqttExporter::periodic(const BusState& state, Nanos now) {
    for (std::uint32_t slot = 0; slot < state.slot_count(); ++slot) {
        publish_value(state, slot, true);
    }
    for (const std::uint8_t address : seen_slaves_) publish_slave_health(state, address);
    publish_bus_health(state, now);
}

void MqttExporter::time_driven(const BusState& state, Nanos now) {
    if (!has_time(now)) return;
    if (!has_time(last_check_) || now - last_check_ >= kCheckEvery || now < last_check_) {
        check_slaves(state, now);
        last_check_ = now;
    }
    if (!has_time(last_periodic_) || now - last_periodic_ >= interval_ || now < last_periodic_) {
        periodic(state, now);
        last_periodic_ = now;
    }
}

void MqttExporter::record(const BusState& state, const Record& record) {
    const Nanos now = state.last_time();
    if (connection_->take_republish()) publish_everything(state, now);
    if (record.kind != Kind::noise) saw_slave(record);
    const bool writes = (record.kind == Kind::request || record.kind == Kind::broadcast) &&
                        std::any_of(record.decoded.blocks.begin(), record.decoded.blocks.end(),
                                    [](const DataBlock& b) { return b.write; });
    for (const std::uint32_t slot : state.updated_slots()) {
        publish_value(state, slot, false);
        if (writes) publish_write(state, state.at_slot(slot), record);
    }
    time_driven(state, now);
}

void MqttExporter::tick(const BusState& state, Nanos now) {
    if (has_time(state.last_time()) && (!has_time(now) || state.last_time() > now)) {
        now = state.last_time();
    }
    if (connection_->take_republish()) publish_everything(state, now);
    time_driven(state, now);
}

void MqttExporter::end(const BusState& state) {
    if (ended_) return;
    ended_ = true;
    const Nanos now = state.last_time();
    // A short input can end before the connection is made: the republish that follows
    // it (what the queue dropped meanwhile, discovery) is still to come.
    const auto deadline = Clock::now() + kFlushBound;
    connection_->wait_connected(deadline);
    if (connection_->take_republish()) {
        publish_everything(state, now);
    } else {
        for (const std::uint8_t address : seen_slaves_) publish_slave_health(state, address);
        publish_bus_health(state, now);
    }
    push(base_ + "/$status", "offline");
    connection_->finish(deadline);
}

std::string MqttExporter::summary() const {
    std::string out = fmt::format("mqtt: {} messages published, {} dropped",
                                  connection_->published(), connection_->dropped());
    if (!connection_->ever_connected()) {
        fmt::format_to(std::back_inserter(out), "; never connected to {}:{}", options_.url.host,
                       options_.url.port);
        if (const std::string why = connection_->last_failure(); !why.empty()) {
            fmt::format_to(std::back_inserter(out), " ({})", why);
        }
    }
    return out;
}

}  // namespace

Result<std::unique_ptr<Exporter>> start_mqtt(const MqttOptions& options) {
    MqttOptions o = options;
    if (o.url.prefix.empty()) o.url.prefix = kDefaultPrefix;
    if (o.url.port == 0) o.url.port = o.url.tls ? kMqttsPort : kMqttPort;
    const std::string bus = safe_name(o.bus.empty() ? std::string("bus") : o.bus);
    auto connection = std::make_unique<Connection>(o, o.url.prefix + "/" + bus + "/$status");
    if (Status s = connection->open(); !s) return s.error();
    return std::unique_ptr<Exporter>(std::make_unique<MqttExporter>(o, std::move(connection)));
}

}  // namespace rtuscope
