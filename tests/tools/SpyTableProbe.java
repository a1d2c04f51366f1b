// Runs LCM's lcm-spy (lcm.spy.Spy.main with this JVM's arguments) and, after
// -Dprobe.seconds (default 6) of it receiving, prints lcm-spy's own channel
// table as it would show it on screen: one line per row, tab separated,
// "ROW<TAB>Channel<TAB>Type<TAB>Num Msgs<TAB>...<TAB>Undecodable", after a
// "COLUMNS" line with the column names. The Type column is lcm-spy's lookup
// of the message's fingerprint in its type database (the class name, or
// "?? <fingerprint>" for an unknown type) and Undecodable counts the
// messages its decoder threw on. Run by tests/tools/spy_test.cpp with the
// class path `rocklab spy --print-command` gives lcm-spy.
import java.awt.Component;
import java.awt.Container;
import java.awt.Frame;
import javax.swing.JTable;
import javax.swing.SwingUtilities;
import javax.swing.table.TableModel;

public class SpyTableProbe {
  public static void main(String[] args) throws Exception {
    final int seconds = Integer.parseInt(System.getProperty("probe.seconds", "6"));
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
    Thread.sleep(seconds * 1000L);
    final StringBuilder out = new StringBuilder();
    SwingUtilities.invokeAndWait(() -> {
      for (Frame f : Frame.getFrames()) collect(f, out);
    });
    System.out.print(out);
    System.out.flush();
    System.exit(out.length() > 0 ? 0 : 3);  // 3: lcm-spy showed no table
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
