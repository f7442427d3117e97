#!/usr/bin/env bash
# Make PostgreSQL and MariaDB answer on 127.0.0.1 as tests/servers.py expects them, and a
# Mosquitto MQTT broker as tests/test_mqtt.py expects it:
#   postgresql+psycopg://postgres@127.0.0.1:5432/test   (user postgres, trust on 127.0.0.1)
#   mysql+pymysql://root@127.0.0.1:3306/test           (user root, no password)
#   mqtt://127.0.0.1:1883                               (anonymous)
# A server that already answers is left alone. One that does not is started if installed, or
# installed with apt-get (Debian/Ubuntu), configured and started. Nothing here fails CI: a
# server that cannot be had is reported, and the tests that need it skip, saying why.
#
# HOMECOG_TEST_POSTGRES_URL / HOMECOG_TEST_MARIADB_URL / HOMECOG_TEST_MQTT_URL (a server
# elsewhere) skip that server; HOMECOG_CI_SERVERS=0 skips them all. HOMECOG_CI_WAIT: seconds to wait for a server (default 60).
set -uo pipefail

PG_PORT="${HOMECOG_CI_PG_PORT:-5432}"
MY_PORT="${HOMECOG_CI_MARIADB_PORT:-3306}"
MQTT_PORT="${HOMECOG_CI_MQTT_PORT:-1883}"
WAIT="${HOMECOG_CI_WAIT:-60}"
export DEBIAN_FRONTEND=noninteractive PGCONNECT_TIMEOUT=5

say() { echo "servers: $*"; }

as_root() {
    if [ "$(id -u)" = 0 ]; then
        "$@"
    elif command -v sudo >/dev/null 2>&1 && sudo -n true 2>/dev/null; then
        sudo -n "$@"
    else
        say "cannot run as root: $*"
        return 1
    fi
}

port_open() { (exec 3<>"/dev/tcp/127.0.0.1/$1") 2>/dev/null; }

wait_for() { # wait_for WHAT COMMAND...: until COMMAND succeeds, at most $WAIT seconds
    local what="$1" i
    shift
    for ((i = 0; i < WAIT; i++)); do
        "$@" >/dev/null 2>&1 && return 0
        sleep 1
    done
    say "$what did not answer within ${WAIT}s"
    return 1
}

apt_updated=""
apt_install() { # apt_install PACKAGE...
    if ! command -v apt-get >/dev/null 2>&1; then
        say "no apt-get here: cannot install $*"
        return 1
    fi
    if [ -z "$apt_updated" ]; then
        say "apt-get update"
        as_root timeout 600 apt-get update -qq || { say "apt-get update failed"; return 1; }
        apt_updated=1
    fi
    say "apt-get install -y $*"
    as_root timeout 900 apt-get install -y -qq --no-install-recommends "$@" ||
        { say "apt-get install $* failed"; return 1; }
}

# -- PostgreSQL ----------------------------------------------------------------------------------
pg_sql() { # as the tests connect: user postgres over TCP
    psql -h 127.0.0.1 -p "$PG_PORT" -U postgres -X -q -t -A "$@"
}

pg_version() { ls /etc/postgresql 2>/dev/null | sort -V | tail -n 1; }

pg_trust() { # let user postgres in from 127.0.0.1 without a password
    local version hba
    version="$(pg_version)"
    hba="/etc/postgresql/$version/main/pg_hba.conf"
    [ -f "$hba" ] || { say "no $hba"; return 1; }
    if as_root grep -Eq '^host[[:space:]]+all[[:space:]]+(all|postgres)[[:space:]]+127\.0\.0\.1/32[[:space:]]+trust' "$hba"; then
        return 0
    fi
    say "postgresql: trust for user postgres on 127.0.0.1 in $hba"
    as_root sed -i '1i host all postgres 127.0.0.1/32 trust  # homecog CI' "$hba"
}

pg_start() {
    local version
    version="$(pg_version)"
    [ -n "$version" ] || { say "postgresql: no cluster in /etc/postgresql"; return 1; }
    if [ ! -d "/etc/postgresql/$version/main" ]; then
        say "postgresql: creating cluster $version/main"
        as_root pg_createcluster "$version" main || return 1
    fi
    pg_trust || return 1
    if as_root pg_ctlcluster "$version" main status >/dev/null 2>&1; then
        say "postgresql: reloading $version/main"
        as_root pg_ctlcluster --skip-systemctl-redirect "$version" main reload
    else
        say "postgresql: starting $version/main"
        as_root pg_ctlcluster --skip-systemctl-redirect "$version" main start
    fi
}

postgres() {
    if [ -n "${HOMECOG_TEST_POSTGRES_URL:-}" ]; then
        say "postgresql: tests use \$HOMECOG_TEST_POSTGRES_URL; nothing to do"
        return 0
    fi
    if port_open "$PG_PORT"; then
        say "postgresql: answering on 127.0.0.1:$PG_PORT"
    else
        if ! command -v pg_ctlcluster >/dev/null 2>&1 || [ -z "$(pg_version)" ]; then
            say "postgresql: not installed"
            apt_install postgresql || return 1
        fi
        pg_start || { say "postgresql: could not start it"; return 1; }
        wait_for "postgresql" port_open "$PG_PORT" || return 1
        say "postgresql: started on 127.0.0.1:$PG_PORT"
    fi
    if ! command -v psql >/dev/null 2>&1; then
        say "postgresql: no psql to check the test database with; assuming it is there"
        return 0
    fi
    if command -v pg_isready >/dev/null 2>&1; then
        wait_for "postgresql" pg_isready -q -h 127.0.0.1 -p "$PG_PORT" || return 1
    fi
    if ! pg_sql -d postgres -c 'SELECT 1' >/dev/null 2>&1; then
        say "postgresql: user postgres cannot log in over TCP without a password; fixing pg_hba.conf"
        pg_start && wait_for "postgresql (user postgres)" pg_sql -d postgres -c 'SELECT 1' || return 1
    fi
    if [ "$(pg_sql -d postgres -c "SELECT 1 FROM pg_database WHERE datname = 'test'")" != 1 ]; then
        say "postgresql: creating database test"
        pg_sql -d postgres -c 'CREATE DATABASE test' || return 1
    fi
    say "postgresql: ready (postgres@127.0.0.1:$PG_PORT/test)"
}

# -- MariaDB ---------------------------------------------------------------------------------------
my_client() { command -v mariadb || command -v mysql; }

my_tcp() { # as the tests connect: root without a password over TCP
    "$(my_client)" -h 127.0.0.1 -P "$MY_PORT" -u root --connect-timeout=5 "$@"
}

my_socket() { # as the OS's root (unix_socket authentication), to set up users
    as_root "$(my_client)" -u root --protocol=socket "$@"
}

my_stopped() { ! start-stop-daemon --status --exec /usr/sbin/mariadbd; }

my_start() {
    local conf=/etc/mysql/mariadb.conf.d/99-homecog-ci.cnf
    if [ -d /etc/mysql/mariadb.conf.d ] && [ ! -f "$conf" ]; then
        say "mariadb: $conf (127.0.0.1 only, no name resolution: root@127.0.0.1 is the test user)"
        printf '[mysqld]\nbind-address = 127.0.0.1\nport = %s\nskip-name-resolve\n' "$MY_PORT" |
            as_root tee "$conf" >/dev/null
        if my_socket -e 'SELECT 1' >/dev/null 2>&1; then # started by the package: restart to apply
            say "mariadb: restarting it to apply $conf"
            as_root mariadb-admin -u root --protocol=socket shutdown >/dev/null 2>&1
            wait_for "mariadb shutdown" my_stopped
        fi
    fi
    if [ ! -d /var/lib/mysql/mysql ]; then
        say "mariadb: initialising /var/lib/mysql"
        as_root mariadb-install-db --user=mysql --datadir=/var/lib/mysql >/dev/null || return 1
    fi
    as_root install -d -o mysql -g mysql /run/mysqld
    say "mariadb: starting /usr/sbin/mariadbd"
    as_root start-stop-daemon --start --oknodo --background --exec /usr/sbin/mariadbd -- --user=mysql
}

mariadb_() {
    if [ -n "${HOMECOG_TEST_MARIADB_URL:-}" ]; then
        say "mariadb: tests use \$HOMECOG_TEST_MARIADB_URL; nothing to do"
        return 0
    fi
    if port_open "$MY_PORT"; then
        say "mariadb: answering on 127.0.0.1:$MY_PORT"
    else
        if [ ! -x /usr/sbin/mariadbd ]; then
            say "mariadb: not installed"
            apt_install mariadb-server mariadb-client || return 1
        fi
        my_start || { say "mariadb: could not start it"; return 1; }
        wait_for "mariadb" port_open "$MY_PORT" || return 1
        say "mariadb: started on 127.0.0.1:$MY_PORT"
    fi
    if [ -z "$(my_client)" ]; then
        say "mariadb: no client to check the test database with; assuming it is there"
        return 0
    fi
    if ! my_tcp -e 'SELECT 1' >/dev/null 2>&1; then
        say "mariadb: creating user root@127.0.0.1 without a password"
        my_socket -e "CREATE USER IF NOT EXISTS 'root'@'127.0.0.1' IDENTIFIED BY '';
            GRANT ALL PRIVILEGES ON *.* TO 'root'@'127.0.0.1' WITH GRANT OPTION; FLUSH PRIVILEGES;" ||
            return 1
        if ! my_tcp -e 'SELECT 1' >/dev/null 2>&1; then # 127.0.0.1 resolved to localhost
            say "mariadb: letting root@localhost log in without a password too"
            my_socket -e "ALTER USER 'root'@'localhost'
                IDENTIFIED VIA unix_socket OR mysql_native_password USING PASSWORD('');" || return 1
        fi
        my_tcp -e 'SELECT 1' >/dev/null || { say "mariadb: root@127.0.0.1 still cannot log in"; return 1; }
    fi
    if [ -z "$(my_tcp -N -e "SHOW DATABASES LIKE 'test'")" ]; then
        say "mariadb: creating database test"
        my_tcp -e 'CREATE DATABASE test' || return 1
    fi
    say "mariadb: ready (root@127.0.0.1:$MY_PORT/test)"
}

# -- Mosquitto ----------------------------------------------------------------------------------
mosquitto_bin() { command -v mosquitto || { [ -x /usr/sbin/mosquitto ] && echo /usr/sbin/mosquitto; }; }

mosquitto_() {
    if [ -n "${HOMECOG_TEST_MQTT_URL:-}" ]; then
        say "mosquitto: tests use \$HOMECOG_TEST_MQTT_URL; nothing to do"
        return 0
    fi
    if port_open "$MQTT_PORT"; then
        say "mosquitto: answering on 127.0.0.1:$MQTT_PORT"
        return 0
    fi
    if [ -z "$(mosquitto_bin)" ]; then
        say "mosquitto: not installed"
        apt_install mosquitto || return 1
    fi
    # our own configuration: the package's may listen elsewhere or want a password
    local conf="${TMPDIR:-/tmp}/homecog-ci-mosquitto.conf"
    printf 'listener %s 127.0.0.1\nallow_anonymous true\npersistence false\n' "$MQTT_PORT" >"$conf"
    say "mosquitto: starting $(mosquitto_bin) -c $conf -d"
    "$(mosquitto_bin)" -c "$conf" -d || { say "mosquitto: could not start it"; return 1; }
    wait_for "mosquitto" port_open "$MQTT_PORT" || return 1
    say "mosquitto: ready (mqtt://127.0.0.1:$MQTT_PORT)"
}

if [ "${HOMECOG_CI_SERVERS:-1}" = 0 ]; then
    say "HOMECOG_CI_SERVERS=0: not touching database or MQTT servers; their tests will skip"
    exit 0
fi
postgres || say "postgresql: unavailable; its tests will skip"
mariadb_ || say "mariadb: unavailable; its tests will skip"
mosquitto_ || say "mosquitto: unavailable; the MQTT tests will skip"
exit 0
