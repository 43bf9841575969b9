#!/usr/bin/env bash
# lcm_spy_decodes.sh BIN_DIR TYPES_JAR: lcm-spy loads ips_types.jar and decodes our live channels.
#
# In a private network namespace (LCM multicast over its loopback only), on an Xvfb display of
# its own:
#  1. SpyProbe (a small Java program compiled here against the real lcm.jar) starts the real
#     lcm-spy (lcm.spy.Spy.main) in its own JVM with our jar on the classpath;
#  2. scripts/lcm-spy (what a user runs) starts too, as a separate process;
#  3. ips-sim --scenario lab publishes SITE, TRUTH, UWB_RANGE and HEALTH live over LCM multicast.
# Asserted (machine-checkable):
#  - both lcm-spy instances print "Found N LCM types" with N = the number of ips classes in the jar;
#  - lcm-spy's channel table (read from its Swing JTable, i.e. what the window shows) lists each of
#    our channels with its type name (SITE site_t, TRUTH pose_t, UWB_RANGE uwb_range_t,
#    HEALTH health_t), messages received and 0 undecodable; no channel on the bus but LCM's own
#    LCM_SELF_TEST probe is unknown or undecodable;
#  - the object lcm-spy decoded last on each channel is an instance of ips.<type> whose utime is
#    within 5 minutes of the wall clock and whose source is not empty;
#  - double-clicking the UWB_RANGE row opens lcm-spy's message viewer without an exception
#    (this needs jchart2d.jar, package libjchart2d-java);
#  - scripts/lcm-spy is still running at the end (it did not die at start);
#  - every struct defined in lcmtypes/*.lcm (read from the files, no list kept here) has its class
#    in the jar, and lcm-spy's own type database (the one it decodes with) maps that class's
#    fingerprint back to it, with the DataInput constructor lcm-spy decodes through: so channels
#    with no traffic here (UWB_TDOA uwb_tdoa_t, UWB_TWR_RAW uwb_twr_timestamps_t, ...) decode too.
# Set IPS_LCM_SPY_SCREENSHOT=FILE.png to keep a screenshot of the display (table and viewer).
# Exit 77 (skipped) when it cannot run here: no namespaces, no java/javac/Xvfb, no AWT X11 support.
# Ends by itself in about 10 s (about 55 s at worst; hard limit 90 s).
set -euo pipefail

skip() { echo "SKIP: $*"; exit 77; }
fail() { echo "FAIL: $*" >&2; exit 1; }

[ $# -eq 2 ] || { echo "usage: $0 BIN_DIR TYPES_JAR" >&2; exit 2; }
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
LCM_JAR=${LCM_JAR:-/usr/share/java/lcm.jar}
CHART_JAR=${JCHART2D_JAR:-/usr/share/java/jchart2d.jar}

if [ "${IPS_SPY_TEST_INNER:-}" != "1" ]; then
  for tool in java javac jar Xvfb unshare ip timeout; do
    command -v "$tool" >/dev/null 2>&1 || skip "'$tool' not found (scripts/install-deps)"
  done
  [ -f "$LCM_JAR" ] || skip "$LCM_JAR not found (package liblcm-java)"
  java_home=$(java -XshowSettings:properties -version 2>&1 | sed -n 's/^ *java.home = //p')
  [ -f "$java_home/lib/libawt_xawt.so" ] ||
    skip "the JRE in $java_home has no AWT X11 support (headless JRE; install default-jre)"
  [ -d "$1" ] || fail "no such bin dir: $1"
  [ -x "$1/ips-sim" ] || fail "$1/ips-sim not found: build first"
  [ -f "$2" ] || fail "types jar not found: $2 (build the ips_types_jar target)"
  [ -f "$CHART_JAR" ] ||
    fail "$CHART_JAR not found: lcm-spy's message viewer needs it (install libjchart2d-java)"
  if [ "$(id -u)" -eq 0 ]; then ns=(--net); else ns=(--user --map-root-user --net); fi
  unshare "${ns[@]}" true 2>/dev/null ||
    skip "cannot create a network namespace here (need root or unprivileged user namespaces)"
  # timeout: hard bound on the whole run. On expiry it signals its whole process group (this
  # script and everything it started; none of them leaves the group), TERM then KILL.
  IPS_SPY_TEST_INNER=1 exec timeout -k 5 110 unshare "${ns[@]}" "$0" "$@"
fi

# --- inside the network namespace ---------------------------------------------------------------
BIN=$(cd "$1" && pwd)
JAR=$(cd "$(dirname "$2")" && pwd)/$(basename "$2")
WORK=$(mktemp -d)
pids=()
shown=0
show_logs() {
  [ "$shown" -eq 0 ] || return 0
  shown=1
  local f
  for f in probe.out script.out xvfb.log; do
    [ -s "$WORK/$f" ] && { echo "--- $f:"; cat "$WORK/$f"; }
  done
  echo "---"
}
cleanup() {
  local rc=$? p
  [ "$rc" -eq 0 ] || show_logs >&2
  for p in "${pids[@]}"; do kill -TERM "$p" 2>/dev/null || true; done
  sleep 0.2
  for p in "${pids[@]}"; do kill -KILL "$p" 2>/dev/null || true; done
  if [ -n "${IPS_LCM_SPY_SCREENSHOT:-}" ] && [ -f "$WORK/spy.png" ]; then
    cp "$WORK/spy.png" "$IPS_LCM_SPY_SCREENSHOT" && echo "screenshot: $IPS_LCM_SPY_SCREENSHOT"
  fi
  rm -rf "$WORK"
}
trap cleanup EXIT
trap 'exit 1' INT TERM
start=$(date +%s.%N)

ip link set lo up
ip link set lo multicast on
ip route add 224.0.0.0/4 dev lo
URL="udpm://239.255.76.67:7667?ttl=0"
export LCM_DEFAULT_URL=$URL
unset CLASSPATH  # lcm-spy also scans $CLASSPATH for types: keep the count exact

# wait_for FILE REGEX SECONDS PID: until FILE has a line matching REGEX (fails if PID died).
wait_for() {
  local i
  for ((i = 0; i < $3 * 10; i++)); do
    grep -Eq "$2" "$1" 2>/dev/null && return 0
    kill -0 "$4" 2>/dev/null || { cat "$1" >&2 || true; fail "process $4 died waiting for /$2/ in $1"; }
    sleep 0.1
  done
  cat "$1" >&2 || true
  fail "timed out after $3 s waiting for /$2/ in $1"
}

# --- a private X display: Xvfb writes its display number to fd 3 when it is ready --------------
# -nolisten unix: only the abstract socket, which lives in this network namespace, so the display
# is private to the test and no file in /tmp/.X11-unix is touched (with -displayfd Xvfb takes no
# lock file; it picks the first display number whose socket it can bind).
Xvfb -displayfd 3 -screen 0 1600x900x24 -nolisten tcp -nolisten unix \
  >"$WORK/xvfb.log" 2>&1 3>"$WORK/display" &
xvfb=$!
pids+=("$xvfb")
wait_for "$WORK/display" '^[0-9]+$' 30 $xvfb
DISPLAY=:$(head -n1 "$WORK/display")
export DISPLAY
echo "Xvfb on $DISPLAY"

ntypes=$(jar tf "$JAR" | grep -Ec '^ips/[^/$]+\.class$') || true
[ "${ntypes:-0}" -gt 0 ] || fail "no ips classes in $JAR"
echo "$JAR: $ntypes ips types"
# Every struct in lcmtypes/*.lcm (all of package ips) has its class in the jar: a message added
# to lcmtypes/ but not to the jar's rule (lcmtypes/CMakeLists.txt), or a stale jar, shows here.
types=$(sed -n 's/^[[:space:]]*struct[[:space:]]\{1,\}\([A-Za-z_][A-Za-z0-9_]*\).*/\1/p' \
  "$ROOT"/lcmtypes/*.lcm | sort -u)
[ -n "$types" ] || fail "no struct found in $ROOT/lcmtypes/*.lcm"
classes=$(jar tf "$JAR")
for t in $types; do
  grep -qx "ips/$t.class" <<<"$classes" || fail "lcmtypes/ defines $t but $JAR has no ips/$t.class"
done
echo "ok:   every struct of lcmtypes/*.lcm ($(echo $types | wc -w)) has its class in the jar"

# --- the probe: the real lcm.spy.Spy in this JVM, its window read back through Swing -----------
mkdir -p "$WORK/probe"
cat >"$WORK/SpyProbe.java" <<'EOF'
import java.awt.*;
import java.awt.event.*;
import java.awt.image.BufferedImage;
import java.io.File;
import java.lang.reflect.*;
import java.util.*;
import java.util.List;
import java.util.concurrent.atomic.AtomicReference;
import javax.imageio.ImageIO;
import javax.swing.*;
import javax.swing.table.TableModel;

/** Starts the real lcm-spy (lcm.spy.Spy.main) and checks what its channel table shows. */
public class SpyProbe {
  static final List<Throwable> uncaught = Collections.synchronizedList(new ArrayList<>());
  static final List<String> failures = new ArrayList<>();

  static void check(boolean ok, String what) {
    System.out.println((ok ? "ok:   " : "FAIL: ") + what);
    if (!ok) failures.add(what);
  }

  interface EdtCall<T> { T call() throws Exception; }
  static <T> T onEdt(EdtCall<T> c) throws Exception {
    AtomicReference<T> r = new AtomicReference<>();
    AtomicReference<Exception> e = new AtomicReference<>();
    SwingUtilities.invokeAndWait(() -> {
      try { r.set(c.call()); } catch (Exception ex) { e.set(ex); }
    });
    if (e.get() != null) throw e.get();
    return r.get();
  }

  static JTable findTable(Container c) {
    for (Component k : c.getComponents()) {
      if (k instanceof JTable) return (JTable) k;
      if (k instanceof Container) { JTable t = findTable((Container) k); if (t != null) return t; }
    }
    return null;
  }

  /** The visible channel table of the "LCM Spy" window, or null. */
  static JTable spyTable() {
    for (Frame f : Frame.getFrames())
      if (f instanceof JFrame && "LCM Spy".equals(f.getTitle()) && f.isShowing())
        return findTable(((JFrame) f).getContentPane());
    return null;
  }

  /** onEdt for a call that reads lcm-spy's channel table. lcm-spy 1.3.1 adds a new channel's row
   *  to its model from its LCM thread, and its TableSorter's row map catches up only on the event
   *  that follows: read in between (a loaded machine makes that likely), the table has one row
   *  more than the map (ArrayIndexOutOfBoundsException in TableSorter.modelIndex). Such a read is
   *  made again once the sorter has caught up, at most 50 times 0.1 s apart. */
  static <T> T onEdtTable(EdtCall<T> c) throws Exception {
    for (int attempt = 1; ; attempt++) {
      try {
        return onEdt(c);
      } catch (ArrayIndexOutOfBoundsException e) {
        if (attempt >= 50) throw e;
        Thread.sleep(100);
      }
    }
  }

  /** One table row as displayed: column name -> cell text. */
  static List<Map<String, String>> rows(JTable t) throws Exception {
    return onEdtTable(() -> {
      List<Map<String, String>> out = new ArrayList<>();
      for (int r = 0; r < t.getRowCount(); r++) {
        Map<String, String> m = new LinkedHashMap<>();
        for (int c = 0; c < t.getColumnCount(); c++)
          m.put(t.getColumnName(c), String.valueOf(t.getValueAt(r, c)).trim());
        out.add(m);
      }
      return out;
    });
  }

  /** The lcm.spy.Spy instance behind its channel table. */
  static Object spyOf(JTable t) throws Exception {
    Field tm = t.getModel().getClass().getDeclaredField("tableModel");  // lcm.util.TableSorter
    tm.setAccessible(true);
    Object inner = tm.get(t.getModel());                                // Spy$ChannelTableModel
    Field outer = inner.getClass().getDeclaredField("this$0");
    outer.setAccessible(true);
    return outer.get(inner);                                            // lcm.spy.Spy
  }

  /** lcm-spy's own per-channel record (lcm.spy.ChannelData) behind the table. */
  @SuppressWarnings("unchecked")
  static Map<String, Object> channelData(JTable t) throws Exception {
    Object spy = spyOf(t);
    Field map = spy.getClass().getDeclaredField("channelMap");
    map.setAccessible(true);
    Field list = spy.getClass().getDeclaredField("channelList");
    list.setAccessible(true);
    synchronized (list.get(spy)) {  // lcm-spy adds channels under this lock
      return new TreeMap<>((Map<String, Object>) map.get(spy));
    }
  }

  static Object pub(Object o, String field) {
    try { return o.getClass().getField(field).get(o); } catch (Exception e) { return null; }
  }

  static String describe(Object msg) {
    StringBuilder sb = new StringBuilder(msg.getClass().getName()).append(" {");
    int n = 0;
    for (Field f : msg.getClass().getFields()) {
      if (Modifier.isStatic(f.getModifiers())) continue;
      if (n++ == 6) { sb.append(" ..."); break; }
      Object v = pub(msg, f.getName());
      String s = v != null && v.getClass().isArray() ? "[" + Array.getLength(v) + "]" : String.valueOf(v);
      sb.append(' ').append(f.getName()).append('=').append(s);
    }
    return sb.append(" }").toString();
  }

  public static void main(String[] args) {
    try {
      run(args);
    } catch (Throwable e) {  // lcm-spy's threads keep the JVM alive: exit explicitly
      System.out.println("FAIL: probe error: " + e);
      e.printStackTrace(System.out);
      System.out.flush();
      Runtime.getRuntime().halt(2);
    }
  }

  static void run(String[] args) throws Exception {
    String url = null, shot = null, open = null;
    List<String> types = new ArrayList<>();
    double timeout = 30;
    Map<String, String> expect = new LinkedHashMap<>();
    for (String a : args) {
      if (a.startsWith("--lcm-url=")) url = a.substring(10);
      else if (a.startsWith("--timeout=")) timeout = Double.parseDouble(a.substring(10));
      else if (a.startsWith("--screenshot=")) shot = a.substring(13);
      else if (a.startsWith("--open=")) open = a.substring(7);
      else if (a.startsWith("--types=")) types.addAll(Arrays.asList(a.substring(8).split(",")));
      else if (a.contains("=")) expect.put(a.substring(0, a.indexOf('=')), a.substring(a.indexOf('=') + 1));
      else throw new IllegalArgumentException("bad argument " + a);
    }
    Thread.setDefaultUncaughtExceptionHandler((th, e) -> {
      uncaught.add(e);
      System.out.println("uncaught exception in " + th.getName() + ": " + e);
      e.printStackTrace(System.out);
    });
    long deadline = System.nanoTime() + (long) (timeout * 1e9);
    final long watchdogMs = (long) (timeout * 1000) + 10_000;
    Thread watchdog = new Thread(() -> {  // never hang the test: dump the threads and quit
      try { Thread.sleep(watchdogMs); } catch (InterruptedException e) { return; }
      System.out.println("FAIL: probe still running after " + watchdogMs + " ms; threads:");
      for (Map.Entry<Thread, StackTraceElement[]> e : Thread.getAllStackTraces().entrySet()) {
        System.out.println("  " + e.getKey());
        for (StackTraceElement f : e.getValue()) System.out.println("      at " + f);
      }
      System.out.flush();
      Runtime.getRuntime().halt(3);
    });
    watchdog.setDaemon(true);
    watchdog.start();

    lcm.spy.Spy.main(url == null ? new String[0] : new String[] {"--lcm-url=" + url});
    JTable table = null;
    while (table == null && System.nanoTime() < deadline) {
      table = onEdt(SpyProbe::spyTable);
      if (table == null) Thread.sleep(100);
    }
    if (table == null) throw new IllegalStateException("no visible 'LCM Spy' window with a table");
    System.out.println("READY");
    System.out.flush();

    // Wait until every expected channel has been received and none is undecodable yet.
    List<Map<String, String>> rows = rows(table);
    while (System.nanoTime() < deadline) {
      rows = rows(table);
      Set<String> seen = new HashSet<>();
      for (Map<String, String> r : rows)
        if (!r.get("Num Msgs").equals("0")) seen.add(r.get("Channel"));
      if (seen.containsAll(expect.keySet())) break;
      Thread.sleep(200);
    }
    Thread.sleep(1500);  // a little more traffic, and one refresh of lcm-spy's rate columns
    rows = rows(table);

    System.out.println("lcm-spy channel table (" + rows.size() + " rows):");
    for (Map<String, String> r : rows) System.out.println("  " + r);
    Map<String, Map<String, String>> byChannel = new HashMap<>();
    for (Map<String, String> r : rows) byChannel.put(r.get("Channel"), r);
    for (Map.Entry<String, String> e : expect.entrySet()) {
      Map<String, String> r = byChannel.get(e.getKey());
      check(r != null, "channel " + e.getKey() + " is in the table");
      if (r == null) continue;
      check(e.getValue().equals(r.get("Type")),
            e.getKey() + ": Type column shows '" + r.get("Type") + "' (expected " + e.getValue() + ")");
      check(Long.parseLong(r.get("Num Msgs")) > 0, e.getKey() + ": " + r.get("Num Msgs") + " messages");
    }
    for (Map<String, String> r : rows)
      if (!r.get("Channel").equals("LCM_SELF_TEST"))  // LCM's own start-up probe, not a type
      check(r.get("Undecodable").equals("0") && !r.get("Type").startsWith("??"),
            r.get("Channel") + ": type " + r.get("Type") + ", undecodable " + r.get("Undecodable"));

    // What lcm-spy decoded: the last message object it built for each channel.
    Map<String, Object> cds = channelData(table);
    long nowUs = System.currentTimeMillis() * 1000L;
    for (Map.Entry<String, String> e : expect.entrySet()) {
      Object cd = cds.get(e.getKey());
      if (cd == null) { check(false, e.getKey() + ": lcm-spy has no ChannelData"); continue; }
      Class<?> cls = (Class<?>) pub(cd, "cls");
      Object last = pub(cd, "last");
      check(cls != null && cls.getName().equals("ips." + e.getValue()),
            e.getKey() + ": decoded with class " + (cls == null ? "none" : cls.getName()));
      if (last == null) { check(false, e.getKey() + ": no decoded message"); continue; }
      System.out.println("  last " + e.getKey() + ": " + describe(last));
      Object utime = pub(last, "utime");
      check(utime instanceof Long && Math.abs((Long) utime - nowUs) < 300_000_000L,
            e.getKey() + ": decoded utime " + utime + " is within 5 min of now (" + nowUs + ")");
      Object source = pub(last, "source");
      check(source instanceof String && !((String) source).isEmpty(),
            e.getKey() + ": decoded source '" + source + "'");
    }

    // Every type of lcmtypes/, as lcm-spy decodes a message: the fingerprint at its head looked up
    // in the type database lcm-spy built from the classpath (Spy.handlers), then the class's
    // DataInput constructor.
    Field hf = spyOf(table).getClass().getDeclaredField("handlers");
    hf.setAccessible(true);
    lcm.spy.LCMTypeDatabase db = (lcm.spy.LCMTypeDatabase) hf.get(spyOf(table));
    for (String name : types) {
      Class<?> cls;
      try {
        cls = Class.forName("ips." + name);
      } catch (ClassNotFoundException e) {
        check(false, "type " + name + ": no class ips." + name + " on lcm-spy's classpath");
        continue;
      }
      long fp = cls.getField("LCM_FINGERPRINT").getLong(null);
      Class<?> found = db.getClassByFingerprint(fp);
      boolean decodes = false;
      try { cls.getConstructor(java.io.DataInput.class); decodes = true; } catch (NoSuchMethodException e) { }
      check(found == cls && decodes, "type " + name + ": lcm-spy maps fingerprint "
            + String.format("%016x", fp) + " to " + (found == null ? "nothing" : found.getName())
            + (decodes ? "" : ", and the class has no DataInput constructor"));
    }

    // Double-click a row, as a user does: lcm-spy opens its message viewer (ObjectPanel).
    if (open != null) {
      final JTable t = table;
      final String ch = open;
      Boolean clicked = onEdtTable(() -> {
        for (int r = 0; r < t.getRowCount(); r++) {
          if (!ch.equals(String.valueOf(t.getValueAt(r, 0)))) continue;
          Rectangle cell = t.getCellRect(r, 0, true);
          int x = cell.x + cell.width / 2, y = cell.y + cell.height / 2;
          long when = System.currentTimeMillis();
          t.dispatchEvent(new MouseEvent(t, MouseEvent.MOUSE_PRESSED, when, 0, x, y, 1, false, MouseEvent.BUTTON1));
          t.dispatchEvent(new MouseEvent(t, MouseEvent.MOUSE_RELEASED, when, 0, x, y, 1, false, MouseEvent.BUTTON1));
          t.dispatchEvent(new MouseEvent(t, MouseEvent.MOUSE_CLICKED, when, 0, x, y, 2, false, MouseEvent.BUTTON1));
          return true;
        }
        return false;
      });
      check(clicked, "double-clicked the " + ch + " row");
      JFrame viewer = null;
      long until = System.nanoTime() + 30_000_000_000L;
      while (viewer == null && System.nanoTime() < until && uncaught.isEmpty()) {
        viewer = onEdt(() -> {
          for (Frame f : Frame.getFrames())
            if (f instanceof JFrame && ch.equals(f.getTitle()) && f.isShowing()) return (JFrame) f;
          return null;
        });
        if (viewer == null) Thread.sleep(100);
      }
      check(viewer != null, "message viewer window '" + ch + "' opened");
      if (viewer != null) {  // no window manager: put it beside the table for the screenshot
        final JFrame v = viewer;
        final Window main = SwingUtilities.getWindowAncestor(t);
        onEdt(() -> { main.toFront(); v.setLocation(main.getWidth(), 0); v.toFront(); return null; });
      }
      Thread.sleep(1500);  // let it paint a few updates
    }
    check(uncaught.isEmpty(), "no uncaught exception in lcm-spy (" + uncaught.size() + ")");

    if (shot != null) {
      Rectangle screen = new Rectangle(Toolkit.getDefaultToolkit().getScreenSize());
      BufferedImage img = new Robot().createScreenCapture(screen);
      ImageIO.write(img, "png", new File(shot));
    }
    System.out.println(failures.isEmpty() ? "PROBE PASS" : "PROBE FAIL: " + failures.size() + " check(s)");
    System.out.flush();
    // halt, not exit: lcm-spy's threads would keep the JVM alive, and no shutdown hook may hang us.
    Runtime.getRuntime().halt(failures.isEmpty() ? 0 : 1);
  }
}
EOF
javac -nowarn -cp "$LCM_JAR" -d "$WORK/probe" "$WORK/SpyProbe.java" || fail "javac SpyProbe.java"
CP="$LCM_JAR:$JAR:$CHART_JAR:$WORK/probe"

java -Djava.net.preferIPv4Stack=true -Xmx256m -cp "$CP" SpyProbe --lcm-url="$URL" --timeout=60 \
  --open=UWB_RANGE --screenshot="$WORK/spy.png" --types="$(echo $types | tr ' ' ',')" \
  SITE=site_t TRUTH=pose_t UWB_RANGE=uwb_range_t HEALTH=health_t >"$WORK/probe.out" 2>&1 &
probe=$!
pids+=("$probe")

# --- what a user runs ---------------------------------------------------------------------------
"$ROOT/scripts/lcm-spy" --jar "$JAR" --lcm-url="$URL" >"$WORK/script.out" 2>&1 &
script=$!
pids+=("$script")

wait_for "$WORK/probe.out" '^READY$' 60 $probe
wait_for "$WORK/script.out" 'Found [0-9]+ plugins' 60 $script

# --- traffic ------------------------------------------------------------------------------------
# Traffic for as long as the probe may wait for every channel (the cleanup stops it).
"$BIN/ips-sim" --scenario lab --duration 120 --log-level warn --lcm-url "$URL" &
sim=$!
pids+=("$sim")

rc=0
wait $probe || rc=$?
show_logs

grep -qx "Found $ntypes LCM types" "$WORK/probe.out" ||
  fail "lcm-spy (probe) did not print 'Found $ntypes LCM types'"
echo "ok:   lcm-spy (probe) printed 'Found $ntypes LCM types'"
grep -qx "Found $ntypes LCM types" "$WORK/script.out" ||
  fail "scripts/lcm-spy did not print 'Found $ntypes LCM types'"
echo "ok:   scripts/lcm-spy printed 'Found $ntypes LCM types'"
kill -0 $script 2>/dev/null || fail "scripts/lcm-spy is no longer running"
echo "ok:   scripts/lcm-spy still running"
[ "$rc" -eq 0 ] || fail "lcm-spy probe failed (status $rc), see its output above"
echo "PASS ($(awk -v s="$start" -v e="$(date +%s.%N)" 'BEGIN{printf "%.1f", e-s}') s)"
