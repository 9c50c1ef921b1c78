// TscLogDump: prints every event of an lcm-logger log, decoded with the tsc and jaguar types.
//
//   java -jar tscd-logdump.jar LOGFILE
//
// One line per event: "<log utime> <channel> <type> field=value ...". Nested structs are
// flattened with dotted paths (places[0].id.robot=7), numeric arrays print as [a,b,...], byte
// arrays as 0x<hex>, strings JSON-quoted. The type is chosen by channel name (DESIGN §4):
//
//   TSC_ANNOUNCE      tsc.announce_t         TSC_REQUEST_<robot>  tsc.memory_request_t
//   TSC_EVENT_<robot> tsc.place_event_t      JAGUAR_CMD_<robot>   jaguar.motor_command_t
//   TSC_MEMORY_<robot> tsc.memory_portion_v2_t (protocol 4; tsc.memory_portion_t of protocols
//                      2-3 where the fingerprint says so)  JAGUAR_STATE_<robot> jaguar.motor_state_t
//   TSC_STATS_<robot> tsc.stats_t
//
// Other channels print as "<log utime> <channel> - <n> bytes" and are not an error. An event
// on a TSC_* or JAGUAR_* channel that does not decode (unknown channel, fingerprint mismatch,
// truncated, or bytes left over) is reported on stderr and makes the exit status 1.
// Exit status: 0 every tsc event decoded, 1 an event did not decode or the log is unreadable,
// 2 usage error.
package tscd.tools;

import java.io.EOFException;
import java.io.IOException;
import java.lang.reflect.Array;
import java.lang.reflect.Constructor;
import java.lang.reflect.Field;
import java.lang.reflect.Modifier;
import java.util.ArrayList;
import java.util.List;

import lcm.lcm.LCMDataInputStream;
import lcm.lcm.LCMEncodable;
import lcm.logging.Log;

public final class TscLogDump {
  private TscLogDump() {}

  /** A channel naming rule: an exact name or a prefix followed by the robot id. */
  private static final class Route {
    final String name;
    final boolean prefix;
    /** The channel's type, then older versions of it that old logs hold (tried in order). */
    final List<Class<? extends LCMEncodable>> types;

    @SafeVarargs
    Route(String name, boolean prefix, Class<? extends LCMEncodable>... types) {
      this.name = name;
      this.prefix = prefix;
      this.types = java.util.Arrays.asList(types);
    }

    boolean matches(String channel) {
      return prefix ? channel.startsWith(name) && channel.length() > name.length()
                    : channel.equals(name);
    }
  }

  private static final Route[] ROUTES = {
    new Route("TSC_ANNOUNCE", false, tsc.announce_t.class),
    new Route("TSC_EVENT_", true, tsc.place_event_t.class),
    new Route("TSC_MEMORY_", true, tsc.memory_portion_v2_t.class, tsc.memory_portion_t.class),
    new Route("TSC_REQUEST_", true, tsc.memory_request_t.class),
    new Route("TSC_STATS_", true, tsc.stats_t.class),
    new Route("JAGUAR_CMD_", true, jaguar.motor_command_t.class),
    new Route("JAGUAR_STATE_", true, jaguar.motor_state_t.class),
  };

  /** Channels that must decode: everything tscd or the Jaguar driver publishes. */
  static boolean isTscChannel(String channel) {
    return channel.startsWith("TSC_") || channel.startsWith("JAGUAR_");
  }

  static Route routeFor(String channel) {
    for (Route route : ROUTES) {
      if (route.matches(channel)) {
        return route;
      }
    }
    return null;
  }

  /** The first of the route's types that decodes `data`; else the newest type's failure. */
  static LCMEncodable decodeAny(Route route, byte[] data) throws Exception {
    Exception first = null;
    for (Class<? extends LCMEncodable> type : route.types) {
      try {
        return decode(type, data);
      } catch (Exception e) {
        if (first == null) {
          first = e;
        }
      }
    }
    throw first;
  }

  /**
   * Decodes one message strictly: the fingerprint must match (the generated constructor checks
   * it) and every byte must be consumed.
   */
  static LCMEncodable decode(Class<? extends LCMEncodable> type, byte[] data) throws Exception {
    LCMDataInputStream in = new LCMDataInputStream(data);
    Constructor<? extends LCMEncodable> constructor =
        type.getConstructor(java.io.DataInput.class);
    LCMEncodable message;
    try {
      message = constructor.newInstance(in);
    } catch (java.lang.reflect.InvocationTargetException e) {
      Throwable cause = e.getCause();
      throw new IOException(cause == null ? e.toString() : cause.toString(), cause);
    }
    if (in.available() != 0) {
      throw new IOException(in.available() + " bytes left over after decoding");
    }
    return message;
  }

  /** The message's own fields in declaration order (public, not static). */
  private static List<Field> fieldsOf(Class<?> type) {
    List<Field> fields = new ArrayList<>();
    for (Field field : type.getDeclaredFields()) {
      int mod = field.getModifiers();
      if (Modifier.isPublic(mod) && !Modifier.isStatic(mod)) {
        fields.add(field);
      }
    }
    return fields;
  }

  private static String quote(String s) {
    StringBuilder out = new StringBuilder("\"");
    for (int i = 0; i < s.length(); ++i) {
      char c = s.charAt(i);
      switch (c) {
        case '"': out.append("\\\""); break;
        case '\\': out.append("\\\\"); break;
        case '\n': out.append("\\n"); break;
        case '\t': out.append("\\t"); break;
        default:
          if (c < 0x20) {
            out.append(String.format("\\u%04x", (int) c));
          } else {
            out.append(c);
          }
      }
    }
    return out.append('"').toString();
  }

  private static boolean isStruct(Class<?> type) {
    return LCMEncodable.class.isAssignableFrom(type);
  }

  /** A scalar, string or (nested) array of scalars as one token. */
  private static void appendValue(StringBuilder out, Object value) {
    if (value == null) {
      out.append("null");
    } else if (value instanceof String) {
      out.append(quote((String) value));
    } else if (value instanceof byte[]) {
      out.append("0x");
      for (byte b : (byte[]) value) {
        out.append(String.format("%02x", b & 0xff));
      }
    } else if (value.getClass().isArray()) {
      out.append('[');
      int n = Array.getLength(value);
      for (int i = 0; i < n; ++i) {
        if (i > 0) {
          out.append(',');
        }
        appendValue(out, Array.get(value, i));
      }
      out.append(']');
    } else {
      out.append(value);
    }
  }

  /** Appends " path=value" for every leaf of `value`, recursing into structs. */
  private static void appendFields(StringBuilder out, String path, Object value)
      throws IllegalAccessException {
    if (value != null && isStruct(value.getClass())) {
      for (Field field : fieldsOf(value.getClass())) {
        String child = path.isEmpty() ? field.getName() : path + "." + field.getName();
        appendFields(out, child, field.get(value));
      }
      return;
    }
    if (value != null && value.getClass().isArray()
        && isStruct(innermostComponent(value.getClass()))) {
      int n = Array.getLength(value);
      if (n == 0) {
        out.append(' ').append(path).append("=[]");
      }
      for (int i = 0; i < n; ++i) {
        appendFields(out, path + "[" + i + "]", Array.get(value, i));
      }
      return;
    }
    out.append(' ').append(path).append('=');
    appendValue(out, value);
  }

  private static Class<?> innermostComponent(Class<?> type) {
    while (type.isArray()) {
      type = type.getComponentType();
    }
    return type;
  }

  /** The printed line for one decoded message (without the log time and channel). */
  static String format(LCMEncodable message) throws IllegalAccessException {
    StringBuilder out = new StringBuilder(message.getClass().getName());
    appendFields(out, "", message);
    return out.toString();
  }

  private static void usage(java.io.PrintStream stream) {
    stream.println("usage: TscLogDump LOGFILE");
    stream.println("Prints every event of an lcm-logger log decoded with the tsc/jaguar types;");
    stream.println("exit status 1 when an event on a TSC_*/JAGUAR_* channel does not decode.");
  }

  public static void main(String[] args) {
    if (args.length == 1 && (args[0].equals("-h") || args[0].equals("--help"))) {
      usage(System.out);
      System.exit(0);
    }
    if (args.length != 1 || args[0].startsWith("-")) {
      usage(System.err);
      System.exit(2);
    }
    String path = args[0];
    long events = 0;
    long decoded = 0;
    long failed = 0;
    Log log;
    try {
      log = new Log(path, "r");
    } catch (IOException e) {
      System.err.println("TscLogDump: cannot open " + path + ": " + e.getMessage());
      System.exit(1);
      return;
    }
    StringBuilder line = new StringBuilder();
    while (true) {
      Log.Event event;
      try {
        event = log.readNext();
      } catch (EOFException e) {
        break;
      } catch (IOException e) {
        System.err.println("TscLogDump: " + path + ": unreadable after event " + events + ": "
                           + e.getMessage());
        System.exit(1);
        return;
      }
      ++events;
      line.setLength(0);
      line.append(event.utime).append(' ').append(event.channel).append(' ');
      Route route = routeFor(event.channel);
      if (route == null) {
        if (isTscChannel(event.channel)) {
          ++failed;
          System.err.println("TscLogDump: " + path + ": event " + event.eventNumber
                             + " on " + event.channel + ": no tsc type for this channel");
        }
        line.append("- ").append(event.data.length).append(" bytes");
        System.out.println(line);
        continue;
      }
      try {
        line.append(format(decodeAny(route, event.data)));
        ++decoded;
      } catch (Exception e) {
        ++failed;
        System.err.println("TscLogDump: " + path + ": event " + event.eventNumber + " on "
                           + event.channel + " is not a valid "
                           + route.types.get(0).getName() + ": "
                           + e.getMessage());
        line.setLength(0);
        line.append(event.utime).append(' ').append(event.channel).append(" ! ")
            .append(event.data.length).append(" bytes, not a ")
            .append(route.types.get(0).getName());
      }
      System.out.println(line);
    }
    try {
      log.close();
    } catch (IOException e) {
      // Read-only: nothing was lost.
    }
    System.err.println("TscLogDump: " + events + " events, " + decoded + " decoded, " + failed
                       + " undecodable");
    System.exit(failed == 0 ? 0 : 1);
  }
}
