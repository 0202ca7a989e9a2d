// FMI4j (Maven Central info.laht.fmi4j:fmi-import) as the master of the cases in a text file
// (tests/python/test_masters.py writes it): java -cp 'JARS/*' Fmi4jDriver.java CASES.txt OUT.txt
// Each case: the GearMesh FMU and the Ramps FMU stepped together at a fixed communication step,
// Jacobi style (at t the Ramps outputs at t go to GearMesh's inputs, then both step to t + h);
// parameters set before initialization, the ramps' start values in Initialization Mode.
// CASES.txt: blocks of lines "case NAME", "fmu PATH", "ramps PATH", "step H", "stop T",
// "param TYPE NAME VALUE", "ramp NAME VALUE", "connect OUTPUT INPUT", "output NAME", "end".
// OUT.txt: per case "case NAME", then "row T V1 V2 ..." after every step, or "error MESSAGE".
import java.io.File;
import java.io.PrintWriter;
import java.nio.file.Files;
import java.util.ArrayList;
import java.util.LinkedHashMap;
import java.util.List;
import java.util.Map;

import no.ntnu.ihb.fmi4j.importer.fmi2.CoSimulationSlave;
import no.ntnu.ihb.fmi4j.importer.fmi2.Fmu;

public class Fmi4jDriver {
    static final class Case {
        String name, fmu, ramps;
        double step, stop;
        List<String[]> params = new ArrayList<>();
        Map<String, Double> ramp = new LinkedHashMap<>();
        List<String[]> connections = new ArrayList<>();
        List<String> outputs = new ArrayList<>();
    }

    static long vr(CoSimulationSlave s, String name) {
        return s.getModelDescription().getModelVariables().getValueReference(name);
    }

    static void check(boolean ok, CoSimulationSlave s, String what) {
        if (!ok) throw new IllegalStateException(what + " failed on " + s.getInstanceName() + " with status " + s.getLastStatus());
    }

    static void run(Case c, PrintWriter out) throws Exception {
        out.println("case " + c.name);
        try (Fmu gmFmu = Fmu.from(new File(c.fmu)); Fmu rampsFmu = Fmu.from(new File(c.ramps))) {
            CoSimulationSlave gm = gmFmu.asCoSimulationFmu().newInstance("gearmesh");
            CoSimulationSlave ramps = rampsFmu.asCoSimulationFmu().newInstance("ramps");
            try {
                check(gm.setupExperiment(0.0, -1.0, 0.0), gm, "setupExperiment");
                check(ramps.setupExperiment(0.0, -1.0, 0.0), ramps, "setupExperiment");
                for (String[] p : c.params) {
                    long[] ref = {vr(gm, p[1])};
                    switch (p[0]) {
                        case "Real": gm.writeReal(ref, new double[] {Double.parseDouble(p[2])}); break;
                        case "Integer": gm.writeInteger(ref, new int[] {Integer.parseInt(p[2])}); break;
                        case "Boolean": gm.writeBoolean(ref, new boolean[] {Boolean.parseBoolean(p[2])}); break;
                        default: throw new IllegalArgumentException(p[0]);
                    }
                }
                for (Map.Entry<String, Double> e : c.ramp.entrySet())
                    ramps.writeReal(new long[] {vr(ramps, e.getKey())}, new double[] {e.getValue()});
                check(gm.enterInitializationMode(), gm, "enterInitializationMode");
                check(ramps.enterInitializationMode(), ramps, "enterInitializationMode");
                int n = c.connections.size();
                long[] from = new long[n], to = new long[n];
                for (int i = 0; i < n; i++) {
                    from[i] = vr(ramps, c.connections.get(i)[0]);
                    to[i] = vr(gm, c.connections.get(i)[1]);
                }
                long[] outs = new long[c.outputs.size()];
                for (int i = 0; i < outs.length; i++) outs[i] = vr(gm, c.outputs.get(i));
                double[] values = new double[n], results = new double[outs.length];
                ramps.readReal(from, values);
                gm.writeReal(to, values);
                check(gm.exitInitializationMode(), gm, "exitInitializationMode");
                check(ramps.exitInitializationMode(), ramps, "exitInitializationMode");
                long steps = Math.round(c.stop / c.step);
                for (long k = 0; k < steps; k++) {
                    double t = k * c.step;
                    ramps.readReal(from, values);
                    gm.writeReal(to, values);
                    check(gm.doStep(t, c.step), gm, "doStep at t = " + t);
                    check(ramps.doStep(t, c.step), ramps, "doStep at t = " + t);
                    gm.readReal(outs, results);
                    StringBuilder row = new StringBuilder("row ").append((k + 1) * c.step);
                    for (double r : results) row.append(' ').append(r);
                    out.println(row);
                }
                gm.terminate();
                ramps.terminate();
            } catch (RuntimeException e) {
                out.println("error " + e.getMessage());
            } finally {
                gm.close();
                ramps.close();
            }
        }
    }

    public static void main(String[] args) throws Exception {
        List<Case> cases = new ArrayList<>();
        Case c = null;
        for (String line : Files.readAllLines(new File(args[0]).toPath())) {
            String[] w = line.trim().split("\\s+");
            switch (w[0]) {
                case "case": c = new Case(); c.name = w[1]; break;
                case "fmu": c.fmu = w[1]; break;
                case "ramps": c.ramps = w[1]; break;
                case "step": c.step = Double.parseDouble(w[1]); break;
                case "stop": c.stop = Double.parseDouble(w[1]); break;
                case "param": c.params.add(new String[] {w[1], w[2], w[3]}); break;
                case "ramp": c.ramp.put(w[1], Double.parseDouble(w[2])); break;
                case "connect": c.connections.add(new String[] {w[1], w[2]}); break;
                case "output": c.outputs.add(w[1]); break;
                case "end": cases.add(c); break;
                default: break;
            }
        }
        try (PrintWriter out = new PrintWriter(args[1])) {
            for (Case each : cases) run(each, out);
        }
    }
}
