import time, torch, warp as wp, tempfile
from hydra import compose, initialize_config_dir
from mtbench.trainer.trainer import Trainer
with initialize_config_dir(config_dir="/work/main/conf" if False else __import__("os").path.abspath("conf"), version_base="1.3"):
    cfg = compose("config", overrides=["env.num_envs=24576", "logging.logger=none", "logging.progress=none",
        "checkpoint.every=0", "checkpoint.save_final=false", f"checkpoint.dir={tempfile.mkdtemp()}"])
tr = Trainer(cfg)
env = tr.base_env
def physinfo():
    it = []; con = []
    for _, s in env.blocks:
        d = s.sim.data
        it.append(wp.to_torch(d.solver_niter).float().mean().item()); con.append(int(wp.to_torch(d.nacon)[0]) / s.n)
    return sum(it)/len(it), sum(con)/len(con)
for i in range(20):
    torch.cuda.synchronize(); t0 = time.perf_counter()
    data, stats = tr.collect(); torch.cuda.synchronize(); t1 = time.perf_counter()
    tr.update(data); torch.cuda.synchronize(); t2 = time.perf_counter()
    if i % 3 == 0 or i > 16:
        niter, ncon = physinfo()
        # env-only: 10 steps of the current policy's last actions replayed, synced
        a = data["action"][:, -1].clone()
        torch.cuda.synchronize(); t3 = time.perf_counter()
        for _ in range(10): env._core_step(a)
        torch.cuda.synchronize(); t4 = time.perf_counter()
        print(f"iter {i}: collect {t1-t0:.3f}s update {t2-t1:.3f}s | solver iters {niter:.1f} contacts/world {ncon:.2f} | env-only step {100*(t4-t3):.1f} ms", flush=True)
