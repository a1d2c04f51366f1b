// Runs LCM's lcm-spy (lcm.spy.Spy.main with this JVM's arguments) and, once
// every channel of -Dprobe.expect (comma separated) has a row with a message
// counted, or after -Dprobe.seconds (default 60) of it receiving, whichever
// comes first, prints lcm-spy's own channel table as it would show it on
// screen: one line per row, tab separated,
// "ROW<TAB>Channel<TAB>Type<TAB>Num Msgs<TAB>...<TAB>Undecodable", after a
// "COLUMNS" line with the column names. The Type column is lcm-spy's lookup
// of the message's fingerprint in its type database (the class name, or
// "?? <fingerprint>" for an unknown type) and Undecodable counts the
// messages its decoder threw on. Run by tests/tools/spy_test.cpp with the
// class path `rocklab spy --print-command` gives lcm-spy. Exit codes: 3 no
// table, 4 lcm-spy failed, 5 the probe failed.
import java.awt.Component;
import java.awt.Container;
import java.awt.Frame;
import javax.swing.JTable;
import javax.swing.SwingUtilities;
import javax.swing.table.TableModel;

public class SpyTableProbe {
  public static void main(String[] args) throws Exception {
    final int seconds = Integer.parseInt(System.getProperty("probe.seconds", "60"));
    final String[] expect = System.getProperty("probe.expect", "").isEmpty()
        ? new String[0] : System.getProperty("probe.expect").split(",");
    Thread spy = new Thread(() -> {
      try {
        lcm.spy.Spy.main(args);
      } catch (Exception e) {
        e.printStackTrace();
        System.exit(4);
      }
    });
    spy.setDaemon(true);
    spy.start();
    // A deadline, not a fixed wait: a channel sent once per replay pass
    // (RL_DAQ_CONFIG) reaches a loaded machine's JVM when it reaches it.
    final long end = System.nanoTime() + seconds * 1_000_000_000L;
    final StringBuilder out = new StringBuilder();
    try {
      while (true) {
        out.setLength(0);
        SwingUtilities.invokeAndWait(() -> {
          try {
            for (Frame f : Frame.getFrames()) collect(f, out);
          } catch (IndexOutOfBoundsException e) {
            // lcm-spy adds a channel's row from its LCM thread: its sorter's
            // index can lag the model by a row while it is read. Not a
            // table yet; read again at the next poll.
            out.setLength(0);
          }
        });
        if (allSeen(out.toString(), expect) || System.nanoTime() > end) break;
        Thread.sleep(250);
      }
    } catch (Throwable e) {
      // Anything else ends the probe at once (Swing's threads would keep
      // the JVM, and the test, waiting for its time-out).
      e.printStackTrace();
      System.exit(5);
    }
    System.out.print(out);
    System.out.flush();
    System.exit(out.length() > 0 ? 0 : 3);  // 3: lcm-spy showed no table
  }

  // Every expected channel has a ROW whose "Num Msgs" column is above 0.
  private static boolean allSeen(String table, String[] expect) {
    if (expect.length == 0) return !table.isEmpty();
    int countColumn = -1;
    java.util.Map<String, Long> counts = new java.util.HashMap<>();
    for (String line : table.split("\n")) {
      String[] f = line.split("\t", -1);
      if (f[0].equals("COLUMNS")) {
        countColumn = java.util.Arrays.asList(f).indexOf("Num Msgs");
      } else if (f[0].equals("ROW") && countColumn > 0 && f.length > countColumn) {
        try {
          counts.put(f[1], Long.parseLong(f[countColumn]));
        } catch (NumberFormatException e) {
          // a row still being filled in: not seen yet
        }
      }
    }
    for (String channel : expect) {
      if (counts.getOrDefault(channel, 0L) <= 0) return false;
    }
    return true;
  }

  private static void collect(Component c, StringBuilder out) {
    if (c instanceof JTable) {
      TableModel m = ((JTable) c).getModel();
      out.append("COLUMNS");
      for (int col = 0; col < m.getColumnCount(); col++) out.append('\t').append(m.getColumnName(col));
      out.append('\n');
      for (int row = 0; row < m.getRowCount(); row++) {
        out.append("ROW");
        for (int col = 0; col < m.getColumnCount(); col++) {
          out.append('\t').append(String.valueOf(m.getValueAt(row, col)).trim());
        }
        out.append('\n');
      }
    }
    if (c instanceof Container) {
      for (Component child : ((Container) c).getComponents()) collect(child, out);
    }
  }
}
