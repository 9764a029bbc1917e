// The Java half of tests/lcm/lcm_types.sh: every event of an LCM log, decoded as lcm-spy
// decodes it (its lcm.spy.LCMTypeDatabase finds the type by fingerprint among the classes
// on the CLASSPATH, here build/agvcal-lcmtypes.jar), printed as `CHANNEL TEXT` in the
// canonical text of tests/lcm/message_text.h.
//   java -cp lcm.jar:CLASSES LcmLogText LOG   (CLASSPATH=build/agvcal-lcmtypes.jar)

import java.io.EOFException;
import java.io.PrintStream;
import java.lang.reflect.Array;
import java.lang.reflect.Field;
import java.lang.reflect.Modifier;
import java.nio.charset.StandardCharsets;
import java.util.Arrays;
import java.util.Comparator;

public class LcmLogText {
  static void put(StringBuilder out, Object value) {
    if (value.getClass().isArray()) {
      out.append('[');
      for (int i = 0; i < Array.getLength(value); ++i) {
        if (i > 0) out.append(',');
        put(out, Array.get(value, i));
      }
      out.append(']');
    } else if (value instanceof Float || value instanceof Double) {
      double d = ((Number) value).doubleValue();
      out.append(Double.isNaN(d) ? "nan" : String.format("%016x", Double.doubleToRawLongBits(d)));
    } else if (value instanceof Boolean) {
      out.append((Boolean) value ? 1 : 0);
    } else if (value instanceof String) {
      out.append('"');
      // lcm-gen's Java (1.3.1) makes one char of every byte: Latin-1 gives the bytes back.
      for (byte b : ((String) value).getBytes(StandardCharsets.ISO_8859_1)) out.append(String.format("%02x", b));
      out.append('"');
    } else {
      out.append(((Number) value).longValue());
    }
  }

  public static void main(String[] args) throws Exception {
    PrintStream stdout = System.out;
    System.setOut(System.err);  // the type database says how many types it found
    lcm.spy.LCMTypeDatabase types = new lcm.spy.LCMTypeDatabase();
    System.setOut(stdout);
    lcm.logging.Log log = new lcm.logging.Log(args[0], "r");
    StringBuilder out = new StringBuilder();
    while (true) {
      lcm.logging.Log.Event event;
      try {
        event = log.readNext();
      } catch (EOFException end) {
        break;
      }
      out.append(event.channel).append(' ');
      long fingerprint = 0;
      for (int i = 0; i < 8 && i < event.data.length; ++i) fingerprint = (fingerprint << 8) | (event.data[i] & 0xff);
      Class<?> type = types.getClassByFingerprint(fingerprint);
      if (type == null) {
        out.append("unknown\n");
        continue;
      }
      Object message = type.getConstructor(byte[].class).newInstance((Object) event.data);
      out.append(type.getName());
      Field[] fields = type.getFields();
      Arrays.sort(fields, Comparator.comparing(Field::getName));
      for (Field field : fields) {
        if (Modifier.isStatic(field.getModifiers())) continue;
        out.append(' ').append(field.getName()).append('=');
        put(out, field.get(message));
      }
      out.append('\n');
    }
    System.out.print(out);
  }
}
