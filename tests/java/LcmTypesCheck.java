// For lcmtypes_java_test: finds the Java class of each encoded message file by its fingerprint,
// the way lcm-spy does (lcm.spy.LCMTypeDatabase, over the class path), decodes the message with it
// and prints its class and its primitive and string fields, one message per line. Run as a
// single-file program: java -cp lcm.jar:occmap_lcmtypes.jar LcmTypesCheck.java FILE...
import java.io.ByteArrayInputStream;
import java.io.DataInputStream;
import java.lang.reflect.Field;
import java.lang.reflect.Modifier;
import java.nio.file.Files;
import java.nio.file.Paths;

public class LcmTypesCheck {
  public static void main(String[] args) throws Exception {
    lcm.spy.LCMTypeDatabase types = new lcm.spy.LCMTypeDatabase();
    for (String file : args) {
      byte[] data = Files.readAllBytes(Paths.get(file));
      long fingerprint = new DataInputStream(new ByteArrayInputStream(data)).readLong();
      Class<?> type = types.getClassByFingerprint(fingerprint);
      if (type == null) {
        System.out.println(file + ": no class for fingerprint " + Long.toHexString(fingerprint));
        continue;
      }
      Object message = type.getConstructor(byte[].class).newInstance((Object) data);
      StringBuilder line = new StringBuilder(type.getName());
      for (Field field : type.getFields()) {
        if (Modifier.isStatic(field.getModifiers()))
          continue;
        if (field.getType().isPrimitive() || field.getType() == String.class) {
          line.append(' ').append(field.getName()).append('=').append(field.get(message));
        }
      }
      System.out.println(line);
    }
  }
}
