// Helpers of the MQTT tests: a real broker (Debian's mosquitto) on a free local port with
// a configuration of its own, a subscriber that keeps what the broker delivers, and a
// small JSON reader to check the payloads by their fields.
#pragma once

#include <mosquitto.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fmt/format.h>

#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include "support.hpp"

extern char** environ;  // NOLINT(readability-redundant-declaration): posix_spawn's

namespace rtuscope::test {

inline constexpr const char* kMosquitto = "/usr/sbin/mosquitto";

inline bool have_mosquitto() {
    return ::access(kMosquitto, X_OK) == 0;
}

// A port nothing listens on now: the kernel's pick for a socket bound to port 0.
inline std::uint16_t free_port() {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    addr.sin_port = 0;
    ::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
    socklen_t len = sizeof addr;
    ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
    ::close(fd);
    return ntohs(addr.sin_port);
}

inline bool port_open(std::uint16_t port) {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    addr.sin_port = htons(port);
    const bool ok = ::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0;
    ::close(fd);
    return ok;
}

// Starts args[0] with its output to `output` (a file, or /dev/null); 0 if it could not.
inline pid_t spawn(const std::vector<std::string>& args, const std::string& output = "/dev/null") {
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, output.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    posix_spawn_file_actions_adddup2(&actions, 1, 2);
    pid_t pid = 0;
    const int rc = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    return rc == 0 ? pid : 0;
}

// Runs args[0] with its arguments, quietly; its exit status, -1 if it could not run.
inline int run_program(const std::vector<std::string>& args) {
    const pid_t pid = spawn(args);
    if (pid == 0) return -1;
    int status = 0;
    ::waitpid(pid, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// mosquitto on 127.0.0.1 and a free port, anonymous or with one user; stopped (and
// startable again on the same port) by the test.
class Broker {
  public:
    struct User {
        std::string name;
        std::string password;
    };
    // A listener with TLS: the server's certificate, its key, and the CA that signed it.
    struct Tls {
        std::string ca;
        std::string cert;
        std::string key;
    };
    explicit Broker(std::optional<User> user = std::nullopt, std::optional<Tls> tls = std::nullopt)
        : port_(free_port()) {
        std::string conf = fmt::format(
            "listener {} 127.0.0.1\npersistence false\nlog_dest file {}\n", port_,
            dir_.file("mosquitto.log"));
        if (tls) conf += fmt::format("cafile {}\ncertfile {}\nkeyfile {}\n", tls->ca, tls->cert, tls->key);
        // As root, mosquitto would become the user "mosquitto", who cannot read this
        // directory.
        if (::geteuid() == 0) conf += "user root\n";
        if (user) {
            const std::string passwords = dir_.file("passwords");
            run_program({"/usr/bin/mosquitto_passwd", "-c", "-b", passwords, user->name,
                         user->password});
            conf += "allow_anonymous false\npassword_file " + passwords + "\n";
        } else {
            conf += "allow_anonymous true\n";
        }
        config_ = dir_.write("mosquitto.conf", conf);
    }
    ~Broker() { stop(); }
    Broker(const Broker&) = delete;
    Broker& operator=(const Broker&) = delete;

    // Starts it and waits until it listens; false if it does not within 3 s.
    bool start() {
        pid_ = spawn({kMosquitto, "-c", config_}, dir_.file("mosquitto.log"));
        if (pid_ == 0) return false;
        const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(3);
        while (std::chrono::steady_clock::now() < deadline) {
            if (port_open(port_)) return true;
            std::this_thread::sleep_for(std::chrono::milliseconds(10));
        }
        return false;
    }
    void stop() {
        if (pid_ <= 0) return;
        ::kill(pid_, SIGTERM);
        int status = 0;
        for (int i = 0; i < 200; ++i) {
            if (::waitpid(pid_, &status, WNOHANG) == pid_) {
                pid_ = 0;
                return;
            }
            std::this_thread::sleep_for(std::chrono::milliseconds(10));
        }
        ::kill(pid_, SIGKILL);
        ::waitpid(pid_, &status, 0);
        pid_ = 0;
    }
    [[nodiscard]] std::uint16_t port() const { return port_; }
    [[nodiscard]] std::string url(std::string_view path = "") const {
        return fmt::format("mqtt://127.0.0.1:{}{}", port_, path);
    }
    [[nodiscard]] std::string log() const {
        std::ifstream in(dir_.file("mosquitto.log"));
        return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    }

  private:
    TempDir dir_;
    std::uint16_t port_;
    std::string config_;
    pid_t pid_ = 0;
};

// A CA and a server certificate it signed for 127.0.0.1 (openssl's command line), in
// `dir`; nullopt when openssl is missing or fails.
inline std::optional<Broker::Tls> make_certificates(const TempDir& dir, const std::string& name) {
    const std::string openssl = "/usr/bin/openssl";
    if (::access(openssl.c_str(), X_OK) != 0) return std::nullopt;
    const auto f = [&](const std::string& what) { return dir.file(name + "-" + what); };
    const std::string ext = dir.write(name + "-ext", "subjectAltName=IP:127.0.0.1\n");
    const std::vector<std::vector<std::string>> steps = {
        {openssl, "req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1",
         "-nodes", "-keyout", f("ca.key"), "-out", f("ca.crt"), "-days", "2", "-subj",
         "/CN=rtuscope test CA " + name},
        {openssl, "req", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes",
         "-keyout", f("server.key"), "-out", f("server.csr"), "-subj", "/CN=127.0.0.1"},
        {openssl, "x509", "-req", "-in", f("server.csr"), "-CA", f("ca.crt"), "-CAkey", f("ca.key"),
         "-CAcreateserial", "-out", f("server.crt"), "-days", "2", "-extfile", ext},
    };
    for (const auto& step : steps) {
        if (run_program(step) != 0) return std::nullopt;
    }
    return Broker::Tls{f("ca.crt"), f("server.crt"), f("server.key")};
}

// Subscribes to a topic filter and keeps every message delivered, in order.
class Subscriber {
  public:
    struct Message {
        std::string topic;
        std::string payload;
        bool retained = false;
    };
    Subscriber(std::uint16_t port, const std::string& filter) {
        mosquitto_lib_init();
        client_ = mosquitto_new(nullptr, true, this);
        mosquitto_message_callback_set(client_, [](mosquitto*, void* self,
                                                   const mosquitto_message* m) {
            auto* s = static_cast<Subscriber*>(self);
            {
                const std::lock_guard lock(s->mutex_);
                s->messages_.push_back(
                    {m->topic, std::string(static_cast<const char*>(m->payload),
                                           static_cast<std::size_t>(m->payloadlen)),
                     m->retain});
            }
            s->arrived_.notify_all();
        });
        mosquitto_connect_callback_set(client_, [](mosquitto* c, void* self, int rc) {
            auto* s = static_cast<Subscriber*>(self);
            if (rc == 0) mosquitto_subscribe(c, nullptr, s->filter_.c_str(), 1);
        });
        mosquitto_subscribe_callback_set(client_, [](mosquitto*, void* self, int, int,
                                                     const int*) {
            auto* s = static_cast<Subscriber*>(self);
            {
                const std::lock_guard lock(s->mutex_);
                s->subscribed_ = true;
            }
            s->arrived_.notify_all();
        });
        filter_ = filter;
        connected_ = mosquitto_connect(client_, "127.0.0.1", port, 30) == MOSQ_ERR_SUCCESS &&
                     mosquitto_loop_start(client_) == MOSQ_ERR_SUCCESS;
    }
    ~Subscriber() {
        mosquitto_disconnect(client_);
        mosquitto_loop_stop(client_, true);
        mosquitto_destroy(client_);
    }
    Subscriber(const Subscriber&) = delete;
    Subscriber& operator=(const Subscriber&) = delete;

    // Connected and subscribed within 3 s.
    bool ready() {
        std::unique_lock lock(mutex_);
        return connected_ && arrived_.wait_for(lock, std::chrono::seconds(3), [&] { return subscribed_; });
    }
    // Waits until `done` holds for the messages so far, at most `timeout`.
    bool wait(const std::function<bool(const std::vector<Message>&)>& done,
              std::chrono::milliseconds timeout = std::chrono::milliseconds(5000)) {
        std::unique_lock lock(mutex_);
        return arrived_.wait_for(lock, timeout, [&] { return done(messages_); });
    }
    // The last payload of `topic`, waiting for one at most `timeout`.
    std::optional<std::string> last(const std::string& topic,
                                    std::chrono::milliseconds timeout = std::chrono::milliseconds(3000)) {
        std::optional<std::string> found;
        wait([&](const std::vector<Message>& all) {
            for (auto it = all.rbegin(); it != all.rend(); ++it) {
                if (it->topic == topic) {
                    found = it->payload;
                    return true;
                }
            }
            return false;
        }, timeout);
        return found;
    }
    std::vector<Message> messages() {
        const std::lock_guard lock(mutex_);
        return messages_;
    }

  private:
    mosquitto* client_ = nullptr;
    std::string filter_;
    bool connected_ = false;
    std::mutex mutex_;
    std::condition_variable arrived_;
    std::vector<Message> messages_;
    bool subscribed_ = false;
};

// A JSON value, read by a small recursive reader: enough to check payloads field by field
// (and that they are JSON at all).
struct Json {
    using Object = std::map<std::string, Json>;
    using Array = std::vector<Json>;
    std::variant<std::nullptr_t, bool, double, std::string, Array, Object> v;

    [[nodiscard]] bool is_null() const { return std::holds_alternative<std::nullptr_t>(v); }
    [[nodiscard]] bool is_number() const { return std::holds_alternative<double>(v); }
    [[nodiscard]] bool is_string() const { return std::holds_alternative<std::string>(v); }
    [[nodiscard]] double number() const { return std::get<double>(v); }
    [[nodiscard]] const std::string& string() const { return std::get<std::string>(v); }
    [[nodiscard]] const Array& array() const { return std::get<Array>(v); }
    [[nodiscard]] bool has(const std::string& key) const {
        return std::holds_alternative<Object>(v) && std::get<Object>(v).contains(key);
    }
    [[nodiscard]] const Json& operator[](const std::string& key) const {
        return std::get<Object>(v).at(key);
    }

    // nullopt unless `text` is one JSON value and nothing else.
    static std::optional<Json> parse(std::string_view text) {
        std::size_t i = 0;
        std::optional<Json> j = value(text, i);
        skip(text, i);
        if (!j || i != text.size()) return std::nullopt;
        return j;
    }

  private:
    static void skip(std::string_view t, std::size_t& i) {
        while (i < t.size() && (t[i] == ' ' || t[i] == '\n' || t[i] == '\t' || t[i] == '\r')) ++i;
    }
    static std::optional<std::string> string_at(std::string_view t, std::size_t& i) {
        if (i >= t.size() || t[i] != '"') return std::nullopt;
        std::string out;
        for (++i; i < t.size(); ++i) {
            const char c = t[i];
            if (c == '"') {
                ++i;
                return out;
            }
            if (static_cast<unsigned char>(c) < 0x20) return std::nullopt;
            if (c != '\\') {
                out += c;
                continue;
            }
            if (++i >= t.size()) return std::nullopt;
            switch (t[i]) {
                case '"': case '\\': case '/': out += t[i]; break;
                case 'n': out += '\n'; break;
                case 't': out += '\t'; break;
                case 'r': out += '\r'; break;
                case 'b': out += '\b'; break;
                case 'f': out += '\f'; break;
                case 'u':
                    if (i + 4 >= t.size()) return std::nullopt;
                    out += '?';  // the tests look at ASCII escapes only
                    i += 4;
                    break;
                default: return std::nullopt;
            }
        }
        return std::nullopt;
    }
    static std::optional<Json> value(std::string_view t, std::size_t& i) {
        skip(t, i);
        if (i >= t.size()) return std::nullopt;
        const char c = t[i];
        if (c == '{') {
            Object o;
            ++i;
            skip(t, i);
            if (i < t.size() && t[i] == '}') {
                ++i;
                return Json{o};
            }
            for (;;) {
                skip(t, i);
                auto key = string_at(t, i);
                skip(t, i);
                if (!key || i >= t.size() || t[i] != ':') return std::nullopt;
                ++i;
                auto v = value(t, i);
                if (!v || o.contains(*key)) return std::nullopt;
                o.emplace(*key, std::move(*v));
                skip(t, i);
                if (i < t.size() && t[i] == ',') {
                    ++i;
                    continue;
                }
                if (i < t.size() && t[i] == '}') {
                    ++i;
                    return Json{o};
                }
                return std::nullopt;
            }
        }
        if (c == '[') {
            Array a;
            ++i;
            skip(t, i);
            if (i < t.size() && t[i] == ']') {
                ++i;
                return Json{a};
            }
            for (;;) {
                auto v = value(t, i);
                if (!v) return std::nullopt;
                a.push_back(std::move(*v));
                skip(t, i);
                if (i < t.size() && t[i] == ',') {
                    ++i;
                    continue;
                }
                if (i < t.size() && t[i] == ']') {
                    ++i;
                    return Json{a};
                }
                return std::nullopt;
            }
        }
        if (c == '"') {
            auto s = string_at(t, i);
            if (!s) return std::nullopt;
            return Json{*s};
        }
        for (const auto& [word, j] : {std::pair{"true", Json{true}}, std::pair{"false", Json{false}},
                                      std::pair{"null", Json{nullptr}}}) {
            if (t.substr(i).starts_with(word)) {
                i += std::string_view(word).size();
                return j;
            }
        }
        // -?(0|[1-9][0-9]*)(.[0-9]+)?([eE][+-]?[0-9]+)?
        const std::size_t from = i;
        const auto digits = [&] {
            const std::size_t d = i;
            while (i < t.size() && t[i] >= '0' && t[i] <= '9') ++i;
            return i - d;
        };
        if (i < t.size() && t[i] == '-') ++i;
        const std::size_t first = i;
        const std::size_t n = digits();
        if (n == 0 || (n > 1 && t[first] == '0')) return std::nullopt;
        if (i < t.size() && t[i] == '.') {
            ++i;
            if (digits() == 0) return std::nullopt;
        }
        if (i < t.size() && (t[i] == 'e' || t[i] == 'E')) {
            ++i;
            if (i < t.size() && (t[i] == '+' || t[i] == '-')) ++i;
            if (digits() == 0) return std::nullopt;
        }
        return Json{std::strtod(std::string(t.substr(from, i - from)).c_str(), nullptr)};
    }
};

}  // namespace rtuscope::test
